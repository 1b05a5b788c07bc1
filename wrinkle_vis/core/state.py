"""One evaluated frame of a face: :class:`FaceState`, its points, total :math:`W` and
per-muscle fields.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cached_property, lru_cache
from typing import TYPE_CHECKING

import numpy as np

from .fields import check_field
from .fieldviews import _StateData, _StateFields
from .mesh import TriangleSurface, unit_rows
from .units import face_unit

if TYPE_CHECKING:
    from .face import FaceModel
    from .refinedfields import _RefinedSource
    from .stacked import _StackedMuscles


class FaceState:
    r"""One evaluated frame of a :class:`FaceModel`.

    Attributes
    ----------
    face : FaceModel
        The model it came from.
    activations : dict of str to float
        Every muscle's activation in this frame.
    rest_points : (n, 3) float
        The rest skin.
    deformed_points : (n, 3) float
        The skin after the muscles' displacement, before wrinkles.
    points : (n, 3) float
        The final skin: deformed points plus :math:`W` along the outward unit normal.
    triangles : (m, 3) int
        The skin's triangles.
    W : (n,) float
        Total wrinkle amplitude, :math:`\sum_m H A(\varepsilon) At`, 0 outside every
        active wrinkling region.
    fields : mapping
        ``fields[muscle][name]`` for ``name`` in :data:`FIELD_NAMES`, each ``(n,)``,
        ``nan`` where the muscle does not define it. ``lambda``, ``gamma``, ``l``, ``At``,
        ``eps`` and ``A`` live on the muscle's AOI; ``w``, ``H`` and ``W`` on its
        wrinkling region. A muscle that is not contracting makes no wrinkles (``W`` = 0 on
        its region) although its compression ``eps`` is still reported. Built on access.
    """

    #: Which skin model made the frame (``"geometric"`` or ``"physical"``).
    skin_model: str = "geometric"
    #: Simulated seconds since the start of a simulation (None for a still frame).
    time: float | None = None
    #: ``(n, 3)``: the skin's velocities (face units per second) in a simulated frame.
    velocities: np.ndarray | None = None
    #: ``(n, 3)``: on a physical frame, the muscles' summed displacement its skin was
    #: solved for (:meth:`FaceModel.muscle_displacement`), which refinement reads instead of
    #: computing it again.
    muscle_pull: np.ndarray | None = None

    def __init__(self, face: FaceModel, activations: Mapping[str, float],
                 deformed: np.ndarray, points: np.ndarray, total: np.ndarray,
                 assembly: _StackedMuscles | None, compact: dict[str, np.ndarray],
                 source: _RefinedSource | None = None) -> None:
        self.face = face
        self.activations = dict(activations)
        self.rest_points = face.skin.points
        self.triangles = face.skin.triangles
        self.deformed_points = _readonly(deformed)
        self.points = _readonly(points)
        self.W = _readonly(total)
        self.W_raw = self.W  # the fold guard replaces W and keeps the raw one here
        self.fold_guard = _zeros(len(self.W))  # how much the guard took away, in [0, 1]
        self.fields = _StateFields(_StateData(face, self.deformed_points, assembly, compact,
                                          source))

    @property
    def n_points(self) -> int:
        """Number of skin vertices."""
        return len(self.points)

    @cached_property
    def normals(self) -> np.ndarray:
        """``(n, 3)``: unit normals to shade the final skin with (:meth:`shading_normals`
        of :attr:`points`, computed on first access).
        """
        return self.shading_normals()

    def shading_normals(self, points=None) -> np.ndarray:
        r"""``(n, 3)``: unit normals to shade ``points`` ``(n, 3)`` (default :attr:`points`;
        e.g. :attr:`deformed_points`) with: the rest skin's shading normals turned as the
        frame turns the surface.

        With :math:`g^0_i` and :math:`g_i` the vertex normals of the rest skin and of
        ``points``, and :math:`r_i` the normals the rest skin is shaded with
        (:attr:`FaceModel.rest_normals <wrinkle_vis.core.face.FaceModel.rest_normals>`),

        .. math::

            n_i = R(g^0_i \to g_i)\, r_i, \qquad
            R(a \to b)\, x = (a \cdot b)\, x + v \times x
                + \frac{(v \cdot x)\, v}{1 + a \cdot b}, \quad v = a \times b,

        the smallest rotation taking :math:`g^0_i` to :math:`g_i` (where a normal turned
        over, :math:`g_i`). On an unrefined skin :math:`r = g^0` and :math:`n = g`, the
        vertex normals. On a refined one :math:`r` are the Phong normals that interpolate
        the coarse skin's vertex normals, as a renderer shades the coarse skin around it:
        the refined rest skin is Phong tessellation, only continuous across the coarse
        edges, and shaded with its own facets it shows the coarse skin's facets and
        seams inside the refined region, a raised plateau with sharp sides beside the
        smoothly shaded skin around it (issue 27). The frame's own change (the muscles'
        pull, the wrinkles) is kept whole.
        """
        p = self.points if points is None else points
        g = self.face.skin.vertex_normals(p)
        rest = self.face._rest
        if not rest.interpolated:
            return g
        return unit_rows(_turned(rest.normals, rest.vertex_normals, g))

    def surface(self) -> TriangleSurface:
        """The final skin as a :class:`TriangleSurface`."""
        return TriangleSurface(self.points, self.triangles)

    def field_values(self, key: str, muscle: str | None = None) -> np.ndarray:
        """``(n,)``: field ``key`` of ``muscle``, or its total over the muscles (None; only
        the fields the catalogue gives a total, ``W``: :attr:`W`).

        Raises
        ------
        KeyError
            For an unknown field or muscle, listing them.
        ValueError
            For a field with no total and no muscle.
        """
        spec = check_field(key, muscle)
        if spec.where == "frame":  # a field of the whole frame (fold_guard)
            return getattr(self, key)
        if muscle is None:
            return self.W
        if muscle not in self.face.muscle_names:
            raise KeyError(f"no muscle {muscle!r}; muscles: {', '.join(self.face.muscle_names)}")
        return self.fields[muscle][key]

    def values_at(self, vertices) -> dict[str, Mapping[str, np.ndarray]]:
        """Every field at skin vertices ``vertices`` ``(k,)``: ``{"total": {"W": (k,)},
        muscle: {key: (k,)}}``, the values of :attr:`W` and :attr:`fields` there, for the
        muscles whose AOI holds one of them (every field of the others is ``nan`` there).
        Read from each muscle's compact data: no full-length field is built, but for a
        field whose ``compute`` is not :attr:`~wrinkle_vis.core.fields.FieldSpec.pointwise`.
        """
        vertices = np.asarray(vertices, np.intp)
        out: dict[str, Mapping[str, np.ndarray]] = {"total": {"W": self.W[vertices]}}
        for name in self.face.muscle_names:
            at = self.fields[name].at(vertices)
            if at.defined:
                out[name] = at
        return out

    def summary(self) -> str:
        """A few lines on the frame: activations and the range of each active field."""
        lines = [f"{self.face.name}: {self.n_points} vertices, "
                 f"{len(self.triangles)} triangles"]
        active = {m: a for m, a in self.activations.items() if a > 0}
        lines.append("active muscles: " + (", ".join(f"{m}={a:.2f}" for m, a in active.items())
                                           or "none"))
        unit = face_unit(self.face)
        lines.append(f"W total ({unit}): min {_sig(self.W.min())}  max {_sig(self.W.max())}"
                     f"  nonzero at {np.count_nonzero(self.W)} vertices")
        for m in active:
            f = self.fields[m]
            parts = []
            for key in ("lambda", "gamma", "eps", "At", "H", "A", "W"):
                v = f[key][np.isfinite(f[key])]
                parts.append(f"{key} [{_sig(v.min())}, {_sig(v.max())}]" if len(v) else
                             f"{key} undefined")
            lines.append(f"  {m}: " + "  ".join(parts))
        return "\n".join(lines)


def _sig(value: float) -> str:
    """``value`` with its sign and 4 significant digits, whatever its scale (a face in
    metres has wrinkles of 1e-4): ``+0.0123``, ``-2.5e-05``, ``+0``.
    """
    return f"{float(value):+.4g}"


def _turned(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(n, 3)``: rows of ``x`` turned by the smallest rotation taking the unit rows of
    ``a`` to those of ``b`` (:meth:`FaceState.shading_normals`); ``b`` where ``a`` and
    ``b`` point apart (within 1e-9) or either is zero.
    """
    (x0, x1, x2), (a0, a1, a2), (b0, b1, b2) = x.T, a.T, b.T
    v0, v1, v2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    c = a0 * b0 + a1 * b1 + a2 * b2
    ok = ((1.0 + c > 1e-9) & (a0 * a0 + a1 * a1 + a2 * a2 > 0.0)
          & (b0 * b0 + b1 * b1 + b2 * b2 > 0.0))
    k = np.where(ok, (v0 * x0 + v1 * x1 + v2 * x2) / np.where(ok, 1.0 + c, 1.0), 0.0)
    out = np.empty_like(x)
    out[:, 0] = c * x0 + v1 * x2 - v2 * x1 + k * v0
    out[:, 1] = c * x1 + v2 * x0 - v0 * x2 + k * v1
    out[:, 2] = c * x2 + v0 * x1 - v1 * x0 + k * v2
    return np.where(ok[:, None], out, b)


@lru_cache(maxsize=8)
def _zeros(n: int) -> np.ndarray:
    """``(n,)``: zeros, read-only, shared by the frames of one skin (no allocation a frame)."""
    z = np.zeros(n)
    z.setflags(write=False)
    return z


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    a.setflags(write=False)
    return a
