"""The guard of a frame: the wrinkle step, the pulls, the fans and the face's entry point."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ._base import (  # noqa: F401
    FoldGuard,
    _any_corner,
    _vertex_normals,
    soft_clamp,
)
from .balls import (  # noqa: F401
    _deformed_lows,
    _gaps_skip,
    fold_radii,
)
from .certified import (  # noqa: F401
    Certified,
    _clamp_only,
    certify,
)
from .fans import (  # noqa: F401
    guard_fans,
)
from .pulls import (  # noqa: F401
    pull_terms,
    skin_scale,
)


def guard_wrinkles(W: np.ndarray, radii: np.ndarray, guard: FoldGuard = FoldGuard()
                   ) -> np.ndarray:
    r"""``(n,)``: :math:`W` ``(n,)`` kept below :math:`\eta\, r_{\operatorname{sign} W}`
    (``radii`` ``(n, 2)``: :math:`r_+, r_-`) by :func:`soft_clamp`.
    """
    W = np.asarray(W, dtype=float)
    ids = np.flatnonzero(W)  # W = 0 is never clamped: the nonzero part decides
    w = W[ids]
    bound = guard.eta * np.where(w >= 0, radii[ids, 0], radii[ids, 1])
    out = W.copy()
    out[ids] = soft_clamp(w, np.maximum(bound, 1e-300), guard.knee)
    return out


@dataclass(frozen=True)
class GuardResult:
    """A guarded frame.

    Attributes
    ----------
    deformed : (n, 3) float
        The deformed skin with each pull scaled by ``scale``.
    points : (n, 3) float
        The final skin.
    W : (n,) float
        The guarded wrinkle amplitude.
    scale : (n,) float
        The factor on each vertex's pull (1 where the pull guard does not act).
    acted : (n,) bool
        Where either guard changed the frame.
    """

    deformed: np.ndarray
    points: np.ndarray
    W: np.ndarray
    scale: np.ndarray
    acted: np.ndarray


def _rewrinkled(points: np.ndarray, d2: np.ndarray, W: np.ndarray, W2: np.ndarray,
                moved: np.ndarray, tri: np.ndarray, terms: dict) -> np.ndarray:
    """``(n, 3)``: the final ``points`` with the guarded deformed skin ``d2`` ``(n, 3)``
    where the pull was scaled (``moved`` ``(n,)``) and :math:`x' + W' n'` where the pull
    moved a vertex's ring or the clamp changed ``W`` to ``W2`` ``(n,)``; ``points`` itself
    where neither happened.
    """
    changed_w = W2 != W
    if not (moved.any() or changed_w.any()):
        return points
    if moved.any():  # (where only the clamp acted, no ring moved: no scan of the skin)
        ring = np.zeros(len(points), bool)
        ring[tri[_any_corner(moved, tri)].ravel()] = True
        redo = np.flatnonzero((ring & (W2 != 0.0)) | changed_w)
    else:
        redo = np.flatnonzero(changed_w)
    p2 = points.copy()
    p2[moved] = d2[moved]
    if len(redo):
        p2[redo] = d2[redo] + W2[redo, None] * _vertex_normals(d2, tri, redo, terms)
    return p2


def _clamped(W: np.ndarray, radii, certified: bool, d2: np.ndarray, tri: np.ndarray,
             terms: dict, guard: FoldGuard, deformed: bool, step: np.ndarray | None,
             empty: np.ndarray | None = None, clear: np.ndarray | None = None
             ) -> np.ndarray:
    r"""``(n,)``: :math:`W` ``(n,)`` clamped by :func:`guard_wrinkles` on the rest ``radii``
    ``(n, 2)`` (or a function giving them, called only when they are needed), lowered by
    the deformed skin ``d2``'s (:func:`_deformed_radii`) when ``deformed``; ``W`` itself
    where the clamp is ``certified`` (the identity on the rest radii) and no deformed ball
    shrank. ``step``: the frame's :math:`W n` when ``d2`` is its deformed skin; ``empty``
    ``(n,)`` bool: the vertices whose deformed balls are certified empty (not searched),
    ``clear`` ``(n,)`` bool: those certified empty of triangles (:func:`_gaps_clear`).
    """
    low = _deformed_lows(d2, tri, W, terms, guard, step, empty, clear) if deformed else None
    if certified and low is None:
        return W
    if callable(radii):
        radii = radii()
    if low is not None:
        rows, values = low
        radii = np.array(radii, dtype=float, copy=True)
        radii[rows] = np.minimum(radii[rows], values)
    return guard_wrinkles(W, radii, guard)


def _held_wrinkles(rest: np.ndarray, d2: np.ndarray, p2: np.ndarray, W2: np.ndarray,
                   tri: np.ndarray, guard: FoldGuard, terms: dict
                   ) -> tuple[np.ndarray, np.ndarray]:
    r"""The wrinkles' own step :math:`x' \to x' + W' n'` (``d2`` to ``p2``, ``(n, 3)``)
    held by :func:`skin_scale` against the rest skin's signed areas: the points and ``W2``
    ``(n,)`` scaled by its factor where it is below 1 (as they are elsewhere).
    """
    h = skin_scale(rest, p2, tri, guard.min_area_wrinkles, guard.knee_wrinkles, terms=terms,
                   start=d2)
    held = np.flatnonzero(h < 1.0)
    if not len(held):
        return p2, W2
    p2 = np.array(p2, dtype=float, copy=True)
    p2[held] = d2[held] + h[held, None] * (p2[held] - d2[held])
    W2 = W2.copy()
    W2[held] *= h[held]
    return p2, W2


def guard_frame(rest: np.ndarray, deformed: np.ndarray, points: np.ndarray, W: np.ndarray,
                triangles: np.ndarray, radii: np.ndarray | Callable[[], np.ndarray],
                guard: FoldGuard = FoldGuard(),
                pulls: bool = True, terms: dict | None = None, deformed_radii: bool = False,
                certified: Certified | None = None) -> GuardResult:
    r"""The guards on one frame: ``rest``, ``deformed`` (before :math:`W`) and final
    ``points`` ``(n, 3)``, ``W`` ``(n,)``, ``triangles`` ``(m, 3)``, rest ``radii``
    ``(n, 2)`` (:func:`medial_radii`); ``terms``: :func:`pull_terms` of ``rest``, when cached.

    1. The pulls are scaled by :func:`skin_scale` (no triangle keeps less than
       ``min_area`` of its rest signed area); ``pulls=False`` skips it.
    2. :math:`W` is clamped by :func:`guard_wrinkles` (below :math:`\eta\, r_\pm`); with
       ``deformed_radii``, :math:`r_\pm` at each wrinkled vertex is the lesser of ``radii``
       and the medial radii of the guarded deformed skin itself (the surface :math:`W`
       displaces; the pulls may have pressed it together), its balls empty of its
       triangles (:func:`triangle_radii`), not only of its vertices.
    3. The wrinkles' own step, :math:`x' \to x' + W' n'`, is held to the same rule as the
       pulls, against the guarded deformed skin: :math:`W'` is scaled by
       :func:`skin_scale` of that step (a steep furrow on small triangles would otherwise
       turn them over).
    4. With ``guard.fans`` (or ``"refined"`` on a refined skin's ``terms``): no vertex's
       fan passes through its two rings (:func:`guard_fans`: :math:`W'` scaled back).

    ``certified`` (:func:`certify`): the checks it certifies are skipped (each would have
    returned what skipping gives); a scaled pull voids all but the clamp's (any pull's).
    ``radii`` may be a function giving them, called only where they are needed.

    Where no guard acts, the frame's points are returned as they are (bit for bit).
    Elsewhere the final point is :math:`x' + W' n'`, with :math:`x'` the scaled pull and
    :math:`n'` the area-weighted unit normal of the guarded deformed skin; a vertex whose
    deformed ring moved keeps its own :math:`W` along the new normal.
    """
    tri = np.asarray(triangles, dtype=np.intp)
    rest = np.asarray(rest, dtype=float)
    if terms is None:
        terms = pull_terms(rest, tri)
    cert = certified if certified is not None else Certified(False, False, False, False)
    f = (skin_scale(rest, deformed, tri, guard.min_area, guard.knee, terms=terms)
         if pulls and not cert.pulls else np.ones(len(rest)))
    W = np.asarray(W, dtype=float)
    moved = f < 1.0
    d2, p2 = np.asarray(deformed, dtype=float), np.asarray(points, dtype=float)
    if moved.any():
        d2 = d2.copy()
        d2[moved] = rest[moved] + f[moved, None] * (d2[moved] - rest[moved])
        cert = Certified(False, False, False, cert.clamp)  # (the clamp's is any pull's)
    search, step = deformed_radii and not cert.balls, None if moved.any() else p2 - d2
    empty, clear = _gaps_skip(rest, d2, W, tri, terms, guard, cert.empty, step) if search \
        else (cert.empty, None)
    W2 = _clamped(W, radii, cert.clamp, d2, tri, terms, guard, search, step, empty, clear)
    p2 = _rewrinkled(p2, d2, W, W2, moved, tri, terms)
    if not cert.step:
        p2, W2 = _held_wrinkles(rest, d2, p2, W2, tri, guard, terms)
    if guard.fans is True or (guard.fans == "refined" and terms.get("refined", False)):
        p2, W2 = guard_fans(d2, p2, W2, tri, terms, rest)  # no fan through its two rings
    acted = moved | (W2 != W)
    if p2 is not points:  # (ors of the columns: a reduction over rows of 3 is slow)
        differ = p2 != points
        acted |= differ[:, 0] | differ[:, 1] | differ[:, 2]
    return GuardResult(d2, p2, W2, f, acted)


def guard_amount(rest: np.ndarray, deformed: np.ndarray, points: np.ndarray, W: np.ndarray,
                 result: GuardResult) -> np.ndarray:
    r"""``(n,)`` in ``[0, 1]``: how much the guard took away at each vertex, the field
    ``fold_guard`` (0 where it did not act), from the raw frame (``rest``, ``deformed``,
    ``points`` ``(n, 3)``, ``W`` ``(n,)``) and its :class:`GuardResult`: the largest of the
    pull's reduction :math:`1 - f`, :math:`W`'s, :math:`1 - |W'| / |W|`, and the final
    point's shift relative to the raw displacement,
    :math:`|x'_f - x_f| / (|W| + |x_d - x_r|)` (a vertex whose normal turned with its
    guarded neighbours).
    """
    W = np.asarray(W, dtype=float)
    ratio = np.divide(np.abs(result.W), np.abs(W), out=np.ones(len(W)), where=W != 0)
    amount = np.maximum(1.0 - result.scale, 1.0 - ratio)
    rows = np.flatnonzero(result.acted)
    if len(rows):
        shift = np.linalg.norm(result.points[rows] - np.asarray(points)[rows], axis=1)
        size = np.abs(W[rows]) + np.linalg.norm(
            np.asarray(deformed)[rows] - np.asarray(rest)[rows], axis=1)
        amount[rows] = np.maximum(amount[rows], np.minimum(
            np.divide(shift, size, out=np.ones(len(rows)), where=size > 0), 1.0))
    return amount


def _radii(face, state, guard: FoldGuard, cert: Certified | None):
    r"""``(n, 2)``, or a function giving them: the rest radii the clamp of ``state``'s
    :math:`W` needs (:func:`fold_radii`), given its certificate ``cert``: asked for only
    when the clamp's certificate fails or a deformed ball shrinks (a function), and where
    it fails at some vertices only (``cert.clamp_ok``), searched at the others alone and
    ``inf`` at those that pass. There the clamp is the identity on any radius at or above
    the one :math:`|W|` needs, which every search gives them, and a deformed ball's radius
    below it is taken as it is: the clamp's result is the same, bit for bit, and no search
    that finds a true radius starts elsewhere (``docs/model.md``, "Certified skips").
    """
    if cert is not None and cert.clamp:
        return lambda: fold_radii(face, state.face, state.W, guard)
    ok = None if cert is None else cert.clamp_ok
    if ok is None or not ok.any():
        return fold_radii(face, state.face, state.W, guard)
    radii = np.array(fold_radii(face, state.face, np.where(ok, 0.0, state.W), guard),
                     dtype=float, copy=True)
    radii[ok] = np.inf
    return radii


def guarded(face, state, guard: FoldGuard = FoldGuard()):
    r"""Apply :func:`guard_frame` to a frame ``state`` of ``face`` (unrefined or refined) in
    place: its ``deformed_points``, ``points`` and ``W`` become the guarded ones,
    ``W_raw`` keeps the raw :math:`W` and ``fold_guard`` ``(n,)`` in ``[0, 1]`` says how
    much the guard took away (:func:`guard_amount`). Returns ``state``.

    On the face's own skin, where the pull guard scales a pull, the frame is evaluated
    again on the guarded deformed skin (as the physical skin's frames are, from their
    skin): the compression :math:`\varepsilon` (Eq. 9, 10), :math:`A` and :math:`W` of every
    muscle, and ``state.fields``, are those of the skin the wrinkles sit on; then
    :math:`W` is guarded on it. ``W_raw`` stays the unguarded frame's :math:`W`.

    A refined frame is guarded on its refined skin (the pulls of its vertices as the
    subdivision hierarchy evaluated them), with the rest skin's terms cached on the refined
    face (frames with the same split set share it); its fields stay those of the unguarded
    pull.
    """
    if not np.any(state.W) and state.deformed_points is state.rest_points:
        return state
    cert = certify(face, state, guard)
    if cert is not None and cert.all:  # no check can act: the frame as it is
        return state
    radii = _radii(face, state, guard, cert)  # (a function where the clamp is certified)
    skin = state.face  # the face's own skin, or the refined one of this frame
    terms = getattr(skin._rest, "pull_terms", None)
    if terms is None:
        surface = skin.skin  # (its edges found only where a pull is limited, when the
        terms = skin._rest.pull_terms = pull_terms(  # surface has not found them already)
            surface.points, surface.triangles, vars(surface).get("edges"))
        terms["refined"] = skin is not face  # (no rest gaps on a refined skin: _gap_bounds)
    g = guard_frame(state.rest_points, state.deformed_points, state.points, state.W,
                    state.triangles, radii, guard, terms=terms,
                    deformed_radii=True, certified=cert)
    if not g.acted.any():
        return state
    if state.face is face and np.any(g.scale < 1.0):  # the fields see the guarded pull
        scale, acted = g.scale, g.acted
        del radii  # g's points and W, and the radii, are not needed again: freed first
        fresh = face._frame(dict(state.activations), g.deformed)
        del g
        cert = _clamp_only(face, fresh, guard)  # (the clamp's certificate: any pull's)
        radii = _radii(face, fresh, guard, cert)
        w = guard_frame(state.rest_points, fresh.deformed_points, fresh.points, fresh.W,
                        state.triangles, radii, guard, pulls=False, terms=terms,
                        deformed_radii=True, certified=cert)
        g = GuardResult(w.deformed, w.points, w.W, scale, acted | w.acted)
        state.fields = fresh.fields
    W = np.asarray(state.W)
    amount = guard_amount(state.rest_points, state.deformed_points, state.points, W, g)
    for name, value in (("W_raw", W), ("deformed_points", g.deformed), ("points", g.points),
                        ("W", g.W), ("fold_guard", amount)):
        value = np.asarray(value)
        value.setflags(write=False)
        setattr(state, name, value)
    return state
