"""Editing muscles: mirror across the face's symmetry plane, snap onto the surfaces their
points are declared on, fresh names, moved points.

Pure functions on immutable muscles (numpy only); the app wraps each in an undoable command.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

import numpy as np

from .mesh import closest_points
from .muscle import Muscle
from .units import millimetre

__all__ = ["created", "mirror_name", "mirrored", "reflect", "snapped", "symmetry_plane",
           "unique_name", "with_point"]

_SIDES = (("_L", "_R"), ("_l", "_r"), ("left", "right"), ("Left", "Right"))


def reflect(points, point, normal) -> np.ndarray:
    r"""Reflect points across a plane.

    Parameters
    ----------
    points : (..., 3) array_like
        The points.
    point, normal : (3,) array_like
        A point on the plane and its normal (any length but zero).

    Returns
    -------
    (..., 3) float ndarray
        .. math:: x' = x - 2\,((x - p)\cdot \hat n)\,\hat n
    """
    x = np.asarray(points, dtype=float)
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    return x - 2.0 * ((x - np.asarray(point, dtype=float)) @ n)[..., None] * n


def symmetry_plane(landmarks: Mapping[str, Iterable[float]]) -> tuple[np.ndarray, np.ndarray]:
    """``((3,), (3,))``: point and unit normal of the left-right plane from landmark pairs.

    Pairs are ``name_L`` and ``name_R``; the normal is the mean of the unit ``L - R``
    vectors, the point the mean of their midpoints. Without a pair: the plane ``x = 0``.
    """
    pairs = [(np.asarray(landmarks[k], float), np.asarray(landmarks[k[:-2] + "_R"], float))
             for k in landmarks if k.endswith("_L") and k[:-2] + "_R" in landmarks]
    pairs = [(a, b) for a, b in pairs if np.linalg.norm(a - b) > 0]
    if not pairs:
        return np.zeros(3), np.array([1.0, 0.0, 0.0])
    normal = np.mean([(a - b) / np.linalg.norm(a - b) for a, b in pairs], axis=0)
    point = np.mean([0.5 * (a + b) for a, b in pairs], axis=0)
    return point, normal / np.linalg.norm(normal)


def mirror_name(name: str) -> str:
    """The other side's name: ``x_L`` <-> ``x_R`` (also ``_l``/``_r``, ``left``/``right``);
    a name with no side gets ``_mirrored``.
    """
    for left, right in _SIDES:
        if name.endswith(left):
            return name[: -len(left)] + right
        if name.endswith(right):
            return name[: -len(right)] + left
    return name + "_mirrored"


def unique_name(base: str, taken: Iterable[str]) -> str:
    """``base`` if free, else ``base_2``, ``base_3``... (a trailing ``_<n>`` is replaced)."""
    taken = set(taken)
    if base not in taken:
        return base
    stem = re.sub(r"_\d+$", "", base)
    k = 2
    while f"{stem}_{k}" in taken:
        k += 1
    return f"{stem}_{k}"


def mirrored(muscle: Muscle, point=(0.0, 0.0, 0.0), normal=(1.0, 0.0, 0.0),
             name: str | None = None) -> Muscle:
    """The muscle's twin across a plane (default ``x = 0``).

    Every point parameter is reflected; the ends of a line parameter (``(2, 3)``) swap, so
    the twin's frame is a proper mirror image (its across axis flips with the face). Lengths
    and angles are unchanged. ``name`` defaults to :func:`mirror_name`.
    """
    changes = {}
    for param in muscle.point_parameters:
        arr = reflect(getattr(muscle, param), point, normal)
        changes[param] = arr[::-1] if arr.ndim == 2 else arr
    return muscle.replace(name=name or mirror_name(muscle.name), **changes)


def with_point(muscle: Muscle, param: str, index: int | None, xyz) -> Muscle:
    """The muscle with point parameter ``param`` (row ``index`` of a line) moved to ``xyz``.

    Raises
    ------
    MuscleParameterError
        If the moved muscle is invalid (e.g. zero length); the message says why.
    """
    if param not in muscle.point_parameters:
        raise KeyError(f"{muscle.type_name} muscles have no point parameter {param!r}; "
                       f"they have: {', '.join(muscle.point_parameters)}")
    xyz = np.asarray(xyz, dtype=float).reshape(3)
    if index is None:
        return muscle.replace(**{param: tuple(xyz)})
    arr = np.array(getattr(muscle, param), dtype=float)
    arr[index] = xyz
    return muscle.replace(**{param: arr})


def snapped(muscle: Muscle, surfaces: Mapping, *, like: Muscle | None = None,
            lines: bool = True, tol: float | None = None) -> Muscle:
    """The muscle with each point of its point parameters moved onto the surface the
    parameter is declared on (:meth:`Muscle.point_surfaces`: attachments on the skull,
    insertions on the skin).

    Parameters
    ----------
    muscle : Muscle
        The muscle.
    surfaces : mapping of str to TriangleSurface
        ``{"skin": ..., "skull": ...}``. A surface that is missing is skipped; a ``"skull"``
        given as None means the skin (a face without a skull).
    like : Muscle, optional
        The muscle it was made from (before a mirror, say): only the points that lay on
        their surface in ``like`` (within ``tol``) are snapped, the others keep their place,
        such as the built-in frontalis lines, which lie off the skull to share one frame.
    lines : bool, default True
        Snap the ends of line parameters (``(2, 3)``) too; False leaves them, when they set
        a frame that neighbouring muscles share.
    tol : float, optional
        How near ``like``'s points count as on their surface; default 1e-3 of the skin's
        (else the first surface's) bounding-box diagonal.

    Returns
    -------
    Muscle
        The snapped copy (the same muscle when nothing moved).
    """
    surfaces = dict(surfaces)
    if surfaces.get("skull", ...) is None:
        surfaces["skull"] = surfaces.get("skin")
    if tol is None and like is not None:
        ref = surfaces.get("skin")
        ref = ref if ref is not None else next(s for s in surfaces.values() if s is not None)
        lo, hi = ref.bounds()
        tol = 1e-3 * float(np.linalg.norm(hi - lo))
    changes = {}
    for param, where in muscle.point_surfaces().items():
        surface = surfaces.get(where)
        arr = np.array(getattr(muscle, param), dtype=float)
        if surface is None or (arr.ndim == 2 and not lines):
            continue
        rows = arr.reshape(-1, 3)
        keep = np.zeros(len(rows), dtype=bool)
        if like is not None:
            old = np.asarray(getattr(like, param), dtype=float).reshape(-1, 3)
            keep = np.linalg.norm(closest_points(surface, old) - old, axis=1) > tol
        if keep.all():
            continue
        rows[~keep] = closest_points(surface, rows[~keep])
        changes[param] = rows.reshape(arr.shape)
    return muscle.replace(**changes) if changes else muscle


def created(muscle_type: type[Muscle], name: str, face, at) -> Muscle:
    """A new muscle of ``muscle_type`` called ``name`` with its insertion at ``at`` ``(3,)``
    on the skin of ``face`` (a ``FaceModel``): the type's own :meth:`Muscle.create`, whose
    starting lengths are in millimetres, made on the face scaled to millimetres and scaled
    back when the face is in another unit (:func:`~wrinkle_vis.core.units.millimetre`), so
    that a new muscle on a scan in metres is not 1000 times too big.
    """
    mm = millimetre(face)
    if mm == 1.0:
        return muscle_type.create(name, at, face.skin, face.skull)
    skull = None if face.skull is None else face.skull.with_points(face.skull.points / mm)
    made = muscle_type.create(name, np.asarray(at, float) / mm,
                              face.skin.with_points(face.skin.points / mm), skull)
    return made.transformed(lambda p: np.asarray(p) * mm, mm)
