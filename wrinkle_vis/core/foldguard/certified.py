"""Certified frames: the bounds that prove a frame needs no guard (docs/model.md)."""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from scipy.spatial import cKDTree

from ._base import (  # noqa: F401
    FoldGuard,
    _near_edges,
)
from .balls import (  # noqa: F401
    _nearest_skin_vertices,
    _skin_lift,
    _triangle_seps,
    medial_radii,
    triangle_radii,
)

# ---------------------------------------------------------------- certified skips
#
# Conservative certificates that an unrefined frame of the geometric skin cannot make a
# guard act (``docs/model.md``, "Certified skips"): each is a handful of operations on
# numbers kept per skin and per set of active muscles, and where it holds the exact check it
# stands for is skipped; where it does not, the exact check runs as before. A skipped check
# would have returned exactly what skipping gives (the frame's own arrays), so the frames are
# bit for bit those of the exact checks.

_CERT_MAX_POINTS = 20_000  # larger skins keep no pairs and radii for the certificates
_CERT_REACH = 6.0  # the pairs' reach D, in median edge lengths
_CERT_ASSEMBLIES = 32  # the active sets whose bounds a skin keeps


@dataclass(frozen=True)
class Certified:
    r"""Which checks of :func:`guard_frame` a frame's certificate lets it skip.

    Attributes
    ----------
    pulls : bool
        No triangle can fall below ``min_area`` under the pull (:func:`skin_scale` gives 1).
    step : bool
        No triangle can fall below ``min_area_wrinkles`` under the wrinkles' step.
    balls : bool
        No deformed vertex, and no deformed triangle not incident to the ball's vertex,
        meets any ball :func:`_deformed_radii` tests.
    clamp : bool
        :math:`|W| \le \kappa\eta r` at every vertex with the rest radii: the clamp is
        the identity where the deformed skin's radii are not lower.
    empty : (n,) bool or None
        Where ``balls`` fails: the vertices whose own ball is certified empty
        (:func:`_empty_balls`; :func:`_deformed_lows` does not search them).
    clamp_ok : (n,) bool or None
        Where ``clamp`` fails (:func:`_clamp_only`): the vertices whose :math:`|W|` is at or
        below the clamp's limit (the clamp on the rest radii leaves them as they are).

    Each of ``step``, ``balls`` and ``clamp`` holds for the frame's own pull: where the
    pulls' check scales it, they say nothing (:func:`guard_frame` then runs every check).
    """

    pulls: bool
    step: bool
    balls: bool
    clamp: bool
    empty: np.ndarray | None = field(default=None, compare=False, repr=False)
    clamp_ok: np.ndarray | None = field(default=None, compare=False, repr=False)

    @property
    def all(self) -> bool:
        """Every check certified: the guard cannot act on the frame."""
        return self.pulls and self.step and self.balls and self.clamp


def _skin_bounds(face) -> dict | None:
    r"""What the certificates need of ``face``'s rest skin, computed once and kept with its
    rest frame (None for a skin of more than :data:`_CERT_MAX_POINTS` vertices):

    * ``radii`` ``(n, 2)``: every rest radius in full, as lower bounds
      (:func:`_verified_radii`; the exact checks keep their own, searched as a frame needs),
      at the vertices a muscle's wrinkles may reach (:func:`_may_wrinkle`), 0 (no bound)
      elsewhere;
    * ``sep`` ``(n,)``: each vertex's distance to the nearest other vertex or triangle not
      incident to it, :math:`s_x` (:func:`_triangle_seps`, at the same vertices; elsewhere
      the nearest vertex's), ``near`` ``(n,)``: to the nearest other vertex, and ``L`` the
      longest edge;
    * ``K`` ``(m,)``: :math:`\|E_t^+\|_2 = 1/\sigma_{\min}(E_t)` of each triangle's rest
      edges :math:`E_t = [e_1\ e_2]`, and ``Einv`` ``(m, 2, 3)``: :math:`E_t^+`;
    * ``pairs`` ``(p, 2)`` and ``dist`` ``(p,)``: every pair of vertices at most
      :math:`D` = ``reach`` apart (:data:`_CERT_REACH` median edges).
    """
    rest = face._rest
    got = getattr(rest, "fold_bounds", None)
    if got is not None:
        return got or None
    skin = face.skin
    if skin.n_points > _CERT_MAX_POINTS or skin.n_points < 2:
        rest.fold_bounds = {}
        return None
    pts = np.asarray(skin.points, dtype=float)
    tri = np.asarray(skin.triangles, dtype=np.intp)
    d, _ = skin.kdtree.query(pts, k=2)
    lift = _skin_lift(face)
    rows = _may_wrinkle(face)
    sep, L = _triangle_seps(pts, tri, d[:, 1], lift, rows)  # vertex or triangle not its own
    radii = _verified_radii(pts, rest.normals, skin.kdtree, sep, tri, lift, rows)
    E = np.stack([pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]]], axis=2)
    Einv = np.linalg.pinv(E)  # (m, 2, 3); 0 rows for a triangle with no area
    sv = np.linalg.svd(E, compute_uv=False)
    with np.errstate(divide="ignore"):
        K = np.where(sv[:, 1] > 0, 1.0 / sv[:, 1], np.inf)
    reach = _CERT_REACH * float(np.median(skin.rest_edge_lengths))
    pairs = skin.kdtree.query_pairs(reach, output_type="ndarray").astype(np.int32)
    dist = np.linalg.norm(pts[pairs[:, 0]] - pts[pairs[:, 1]], axis=1)
    rest.fold_bounds = got = {"radii": radii, "sep": sep, "near": d[:, 1], "K": K, "Einv": Einv,
                              "pairs": pairs, "dist": dist, "reach": reach, "L": L,
                              "size": float(np.abs(pts).max()), "assemblies": {}}
    return got


def _may_wrinkle(face, rings: int = 2) -> np.ndarray:
    """``(k,)``: the vertices of ``face``'s skin in any of its muscles' areas of influence
    and ``rings`` rings of edges about them (a refined vertex takes the radii of its three
    nearest skin vertices): where its frames' :math:`W` may be nonzero. A radius left 0
    elsewhere only takes the clamp's certificate from a frame whose :math:`W` reaches there
    (a muscle moved since): ``|W| <= 0`` fails and the exact check runs.
    """
    inside = np.zeros(face.skin.n_points, bool)
    for m in face.muscles:
        inside[face.muscle_data(m).aoi] = True
    edges = np.asarray(face.skin.edges, dtype=np.intp)
    for _ in range(rings):
        grow = inside[edges[:, 0]] | inside[edges[:, 1]]
        inside[edges[grow].ravel()] = True
    return np.flatnonzero(inside)


def _verified_radii(pts: np.ndarray, normals: np.ndarray, tree: cKDTree, sep: np.ndarray,
                    tri: np.ndarray, lift: dict | None = None, rows: np.ndarray | None = None
                    ) -> np.ndarray:
    r"""``(n, 2)``: lower bounds of the rest radii that any search of :func:`fold_radii`
    cannot go below: the search in full (from twice the diagonal), each ball checked empty
    of vertices (0 where the search stopped before it was: its iteration cap), then emptied
    of the triangles (:func:`triangle_radii`, ``tri`` ``(m, 3)``), times
    :math:`1 - 4 \cdot 10^{-9} (r / s)^2` (``sep`` ``(n,)``: :math:`s`, the distance to the
    nearest other vertex or triangle not the vertex's own). A search stops at a ball with no
    vertex or triangle point deeper than
    :math:`10^{-9} r` inside; a vertex that deep in a ball of radius :math:`r` and at
    least :math:`s` from :math:`x` bounds a ball of radius at least
    :math:`r (1 - 2 \cdot 10^{-9} (r / s)^2)` (``docs/model.md``).
    """
    rows = np.arange(len(pts)) if rows is None else np.asarray(rows, dtype=np.intp)
    out = np.zeros((len(pts), 2))
    r_max = 2.0 * float(np.linalg.norm(np.ptp(pts, axis=0)))
    x, n = pts[rows], normals[rows]
    r = medial_radii(x, n, samples=pts, r_max=r_max, tree=tree)
    for col, side in enumerate((1.0, -1.0)):
        dist, _ = tree.query(x + side * r[:, col, None] * n)
        r[dist < r[:, col] * (1.0 - 1e-9), col] = 0.0  # not converged: no bound
    r = triangle_radii(rows, n, r, pts, tri, lift=lift, clear=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        loss = 4e-9 * (r / np.where(sep[rows] > 0, sep[rows], 0.0)[:, None]) ** 2
    out[rows] = np.where(loss < 1.0, r * (1.0 - loss), 0.0)
    return out


def _assembly_bounds(face, asm, skin: dict) -> dict:
    r"""What the certificates need of the active set ``asm`` (a ``_StackedMuscles``), per
    muscle :math:`m` in its order, from its unit displacement :math:`U_m` (the tangent pull
    at activation 1, 0 outside its AOI):

    * ``G`` ``(M,)``: :math:`\hat G_m = \max_t \|J_{m,t}\|_2`, :math:`J_{m,t} = [U_1 - U_0\
      \ U_2 - U_0]\,E_t^+` the gradient of :math:`U_m` on triangle :math:`t`;
    * ``U`` ``(M,)``: :math:`\hat U_m = \max_v |U_m(v)|`;
    * ``Lip`` ``(M,)``: :math:`\max |U_m(v) - U_m(w)| / |x_v - x_w|` over the pairs at most
      :math:`D` apart, and ``LipW`` ``(v, M)``: the same over the pairs of each wrinkled
      vertex (``asm.wrinkled``), :math:`\mathrm{Lip}_m(x)`;
    * ``Gt`` ``(T, M)``: :math:`\|J_{m,t}\|_2` on each triangle with a moved corner, and
      ``Um`` ``(3 u, M)``: :math:`U_m` at the moved vertices (``asm.moved``, their x, y
      and z in turn);

    and of the set: ``Kp``, ``Kw``, the largest :math:`K_t` of the triangles with a moved
    corner and with a wrinkled one; ``S``, the largest Frobenius norm of the slide's shape
    operators; ``sep``, the least :math:`s_x` of the wrinkled vertices.
    """
    memo = skin["assemblies"]  # by the assembly itself: the same names may be other muscles
    got = memo.pop(id(asm), None)
    if got is None or got[0] is not asm:
        got = (asm, _build_assembly_bounds(face, asm, skin))
    memo[id(asm)] = got  # (holding the assembly: its id is not reused while kept)
    while len(memo) > _CERT_ASSEMBLIES:
        memo.pop(next(iter(memo)))
    return got[1]


def _build_assembly_bounds(face, asm, skin: dict) -> dict:
    """:func:`_assembly_bounds`, computed."""
    tri = np.asarray(face.skin.triangles, dtype=np.intp)
    n = face.skin.n_points
    moved = np.zeros(n, bool)
    moved[asm.moved] = True
    pulled = np.flatnonzero(moved[tri].any(axis=1))
    G, U, Lip = [], [], []
    Gt = np.zeros((len(pulled), len(asm.names)))
    Um = np.zeros((len(asm.moved), 3, len(asm.names)))
    LipW = np.zeros((len(asm.wrinkled), len(asm.names)))
    for k, name in enumerate(asm.names):
        data = face.muscle_data(face.muscle(name))
        rows, norms, g, top, lip, lip_v = _muscle_bounds(face, data, skin)
        LipW[:, k] = lip_v[asm.wrinkled]
        G.append(g)
        U.append(top)
        Lip.append(lip)
        Gt[np.searchsorted(pulled, rows), k] = norms  # (its triangles are pulled ones)
        u = np.zeros((n, 3))
        u[data.aoi] = data.unit_disp
        Um[:, :, k] = u[asm.moved]  # (as rows x, y, z of each moved vertex)
    wrinkled = np.zeros(n, bool)
    wrinkled[asm.wrinkled] = True
    K = skin["K"]
    s = asm.slide_s
    frob = np.sqrt(s[0] ** 2 + s[1] ** 2 + s[2] ** 2 + 2.0 * (s[3] ** 2 + s[4] ** 2 + s[5] ** 2))

    def most(values: np.ndarray) -> float:
        return float(values.max()) if len(values) else 0.0

    return {"G": np.array(G), "U": np.array(U), "Lip": np.array(Lip), "Gt": Gt,
            # the triangles near the wrinkled vertices, found when a frame first asks
            "L": partial(_near_edges, np.asarray(face.skin.points, dtype=float),
                         np.asarray(face.skin.triangles, dtype=np.intp), asm.wrinkled,
                         0.5 * skin["reach"]),
            "ULG": np.ascontiguousarray(np.stack([U, Lip, G], axis=1)),
            "Um": np.ascontiguousarray(Um.reshape(-1, len(asm.names))), "LipW": LipW,
            "moved": asm.moved, "wrinkled": asm.wrinkled, "clamp": {},
            "Kp": most(K[moved[tri].any(axis=1)]), "Kw": most(K[wrinkled[tri].any(axis=1)]),
            "S": most(frob),
            # the vertices' separation (the triangles near x: "L", _near_edges)
            "sep": float(skin["near"][asm.wrinkled].min()) if len(asm.wrinkled) else np.inf}


def _muscle_bounds(face, data, skin: dict) -> tuple:
    r"""One muscle's part of :func:`_assembly_bounds`, from its rest data ``data`` (a
    ``_MuscleData``, shared by every face whose muscle has the same geometry, so a drag
    recomputes only the dragged muscle's): the triangles of its AOI ``(t,)`` and
    :math:`\|J_{m,t}\|_2` on them ``(t,)``, :math:`\hat G_m`, :math:`\hat U_m` and its
    Lipschitz bound, over all its pairs and ``(n,)`` over each vertex's. Kept per skin by
    the data itself (held, so its id is not reused).
    """
    memo = skin.setdefault("muscles", {})
    got = memo.pop(id(data), None)
    if got is None or got[0] is not data:
        got = (data, _build_muscle_bounds(face, data, skin))
    memo[id(data)] = got
    while len(memo) > 4 * _CERT_ASSEMBLIES:
        memo.pop(next(iter(memo)))
    return got[1]


def _build_muscle_bounds(face, data, skin: dict) -> tuple:
    """:func:`_muscle_bounds`, computed."""
    tri = np.asarray(face.skin.triangles, dtype=np.intp)
    n = face.skin.n_points
    pairs, dist = skin["pairs"], skin["dist"]
    u = np.zeros((n, 3))
    u[data.aoi] = data.unit_disp
    inside = np.zeros(n, bool)
    inside[data.aoi] = True
    rows = np.flatnonzero(inside[tri].any(axis=1))
    c = tri[rows]
    D = np.stack([u[c[:, 1]] - u[c[:, 0]], u[c[:, 2]] - u[c[:, 0]]], axis=2)
    J = D @ skin["Einv"][rows]
    norms = np.linalg.norm(J, ord=2, axis=(1, 2))
    near = np.flatnonzero(inside[pairs[:, 0]] | inside[pairs[:, 1]])
    p = pairs[near]
    diff = np.linalg.norm(u[p[:, 0]] - u[p[:, 1]], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(diff > 0, diff / dist[near], 0.0)
    lip = np.zeros(n)  # per vertex: the largest ratio of its pairs
    np.maximum.at(lip, p[:, 0], ratio)
    np.maximum.at(lip, p[:, 1], ratio)
    return (rows, norms, float(norms.max()) if len(rows) else 0.0,
            float(np.linalg.norm(u, axis=1).max()), float(ratio.max()) if len(ratio) else 0.0,
            lip)


def _near_of(bounds: dict, R: float) -> dict | None:
    """:func:`_near_table` of the triangles near an active set's wrinkled vertices
    (:func:`_near_edges`, ``bounds["L"]``), found on first use and kept; ``R``: the pairs'
    reach. None for bounds that have none (a test's skin of vertices alone).
    """
    near = bounds.get("L")
    if callable(near):
        near = bounds["L"] = _near_table(near(), len(bounds["wrinkled"]), R)
    return near


_TABLE_STEPS = 32  # the near triangles' bounds are kept at Lambda = j / 32, j = 0..32
_TABLE_CUTS = (0.125, 0.25, 0.5, 1.0)  # and over the triangles within these parts of D


def _near_table(near: tuple, count: int, R: float) -> dict:
    r"""The triangles near ``count`` wrinkled vertices (:func:`_near_edges` ``near``; ``R``
    the pairs' reach) as a table the balls' certificates read in constant time:

    * ``F`` ``(count, c, J + 1)``: per vertex :math:`x`, cut :math:`l` and step :math:`j`,
      :math:`\min_t \max_k \min_i (h_{ki} - \Lambda_j m_i)` over :math:`x`'s triangles with
      :math:`d_{x,t} \le` ``cut[l]`` (:data:`_TABLE_CUTS` of the near triangles' reach
      :math:`D`), :math:`\Lambda_j = j / J` (:data:`_TABLE_STEPS`), ``inf`` where none;
      ``G`` ``(c, J + 1)``: its least over the vertices;
    * ``far`` ``(count,)`` bool: whether a corner of one of :math:`x`'s triangles lies
      beyond the pairs (:math:`m_i > R (1 - 10^{-9})`, its move bounded by :math:`2P`
      alone); ``cut`` ``(c,)``.

    Each entry is non-increasing in :math:`\Lambda` (:math:`m_i \ge 0`) and in the cut
    (a minimum over more triangles), so a frame's :math:`\Lambda` and reach read the entry
    at the next step and cut above them: a lower bound of the one they ask for.
    """
    d, h, m, D, owner = near[:5]
    J = _TABLE_STEPS
    cut = np.array(_TABLE_CUTS) * D
    steps = np.arange(J + 1) / J
    level = np.minimum(np.searchsorted(cut, d, side="left"), len(cut) - 1)
    key = owner * len(cut) + level
    order = np.argsort(key, kind="stable")  # the rows by vertex and cut
    g = np.empty((len(d), J + 1))
    for lo in range(0, len(d), 8192):  # max_k min_i (h_ki - lam_j m_i), 8192 rows at a time
        rows = order[lo:lo + 8192]
        lm = [m[rows, i, None] * steps for i in range(3)]
        for k in range(h.shape[1]):
            hk = h[rows, k]
            low = np.minimum(np.minimum(hk[:, 0, None] - lm[0], hk[:, 1, None] - lm[1]),
                             hk[:, 2, None] - lm[2])
            g[lo:lo + len(rows)] = low if k == 0 else np.maximum(g[lo:lo + len(rows)], low)
    F = np.full((count * len(cut), J + 1), np.inf)
    if len(d):
        key = key[order]
        starts = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
        F[key[starts]] = np.minimum.reduceat(g, starts, axis=0)
    F = np.minimum.accumulate(F.reshape(count, len(cut), J + 1), axis=1)
    far = np.zeros(count, bool)
    far[owner[(m > R * (1.0 - 1e-9)).any(axis=1)]] = True
    return {"F": F, "G": F.min(axis=0) if count else np.full((len(cut), J + 1), np.inf),
            "far": far, "cut": cut, "D": D}


def _table_bounds(table: dict, lam: np.ndarray, far: np.ndarray,
                  rows: np.ndarray | None = None) -> np.ndarray:
    r"""``(k,)``: lower bounds of :math:`\min_t \max_k \min_i (h_{ki} - \Lambda m_i)` over
    the triangles within ``far`` ``(k,)`` of each of the wrinkled vertices ``rows`` ``(k,)``
    (their rows of the table; None: the least over all, :func:`_near_table`'s ``G``) at
    :math:`\Lambda` = ``lam`` ``(k,)``: ``-inf`` where :math:`\Lambda > 1` or ``far``
    exceeds the table's reach.
    """
    J = _TABLE_STEPS
    j = np.ceil(lam * J * (1.0 + 1e-9)).astype(np.intp)  # the next step above lam
    j = np.where(j / J >= lam, j, j + 1)
    l = np.searchsorted(table["cut"], far, side="left")
    ok = (j <= J) & (l < len(table["cut"])) & (lam >= 0)
    j, l = np.where(ok, j, 0), np.where(ok, l, 0)
    got = table["G"][l, j] if rows is None else table["F"][rows, l, j]
    return np.where(ok, got, -np.inf)


def _clamp_limit(skin: dict, bounds: dict, guard: FoldGuard) -> np.ndarray:
    r"""``(v,)``: :math:`(1 - 10^{-5})\,\kappa\,\eta \min(r_+, r_-)` on the rest radii in
    full at the wrinkled vertices of an active set (its ``bounds``), kept per guard:
    :math:`|W|` at or below it leaves the clamp the identity and asks :func:`fold_radii`
    for no search.
    """
    key = (guard.eta, guard.knee)
    got = bounds["clamp"].get(key)
    if got is None:
        r = skin["radii"][bounds["wrinkled"]].min(axis=1)
        got = bounds["clamp"][key] = (1.0 - 1e-5) * guard.knee * guard.eta * r
    return got


def certify(face, state, guard: FoldGuard = FoldGuard()) -> Certified | None:
    r"""The certificates of an unrefined frame ``state`` of ``face``'s geometric skin; of
    any other frame (refined, physical) the clamp's alone (:func:`_clamp_only`); None for a
    skin too large to keep their data.

    With :math:`a_m` the activations, :math:`D = \sum_m a_m U_m` the summed tangent pull and
    :math:`b_v n_v` the slide (:func:`~wrinkle_vis.core.refined.slide_bend`), so the pull is
    :math:`p = D - b\,n`:

    * :math:`D_{\max} = \sum_m a_m \hat U_m`, :math:`b_{\max} = \min(\tfrac12 S D_{\max}^2,
      0.3 D_{\max})`, :math:`P = D_{\max} + b_{\max}` bound :math:`|D|`, :math:`|b|`, :math:`|p|`;
    * :math:`g = \sum_m a_m \hat G_m + 2\sqrt2\,K_p b_{\max}` bounds the pull's gradient on
      every triangle, :math:`\|J_t\|_2`;
    * pulls: :math:`(1 - g/\kappa)^2 \ge \sigma_{\min}` (then
      :math:`\sigma_t(s) = \det(I + s P_t J_t) \ge (1 - s g)^2` on :math:`[0, 1/\kappa]`);
    * step: :math:`g_w = 2\sqrt2\,K_w \max|W|`, :math:`(1 - g - g_w/\kappa_w)^2 \ge
      \sigma_{\min,w}`;
    * balls: :math:`\Lambda' = \max(\sum_m a_m \mathrm{Lip}_m, 2P/D) < 1`,
      :math:`2\rho + 2P \le D/2` and, with :math:`\delta = 2\rho(1 + 10^{-6}) + \tau`,
      :math:`\delta + 2b_{\max} \le s(1 - \Lambda')` and :math:`\le \min_t \max_u \min_i
      (h_i - \Lambda' m_i)` over the triangles within :math:`2\rho + 2P` of a wrinkled
      vertex (:func:`_near_edges`, read off :func:`_near_table`),
      :math:`\rho = \max|W| / (\kappa \eta_d)\,(1 + 10^{-6})` (no deformed vertex but
      :math:`x`, and no triangle not its own, within :math:`2\rho` of :math:`x`); where it
      fails, vertex by vertex (:func:`_balls_per_vertex`);
    * clamp: :math:`|W| \le` :func:`_clamp_limit` everywhere.

    ``docs/model.md`` ("Certified skips") has the proofs.
    """
    if state.face is not face or state.skin_model != "geometric":
        return _clamp_only(face, state, guard)
    acts = state.activations
    active = tuple(n for n, a in acts.items() if a > 0.0)
    if not active:
        return None
    skin = getattr(face._rest, "fold_bounds", None)
    if skin is None:
        skin = _skin_bounds(face)
    if not skin:
        return None
    asm = face._assembly(active)  # the face's own (faces derived by edits share the skin)
    got = skin["assemblies"].get(id(asm))
    bounds = got[1] if got is not None and got[0] is asm else _assembly_bounds(face, asm, skin)
    a = np.array([acts[m] for m in active])
    w = np.abs(np.take(state.W, bounds["wrinkled"]))  # W is 0 off the wrinkled vertices
    w_max = float(w.max()) if len(w) else 0.0
    clamp = bool((w <= _clamp_limit(skin, bounds, guard)).all())
    d_max, lam, g = (a @ bounds["ULG"]).tolist()  # sums of a_m U_m, a_m Lip_m, a_m G_m
    b_max = min(0.5 * bounds["S"] * d_max * d_max, 0.3 * d_max)
    lam *= 1.0 + 1e-9
    pulls, step, balls = _certificates(g, d_max, b_max, lam, w_max, bounds, skin, guard)
    if not (pulls and step and balls):  # the frame's own pull: tighter, a few calls more
        tight = _measured(state, a, (d_max, b_max, lam, w_max), bounds, skin, guard)
        pulls, step, balls = pulls or tight[0], step or tight[1], balls or tight[2]
        d_max, b_max = tight[3], tight[4]
    empty = None
    if not balls:  # each vertex's own ball, on its own |W| and separation
        balls, empty = _balls_per_vertex(len(state.W), a, w, b_max, d_max, bounds, skin,
                                         guard)
    return Certified(bool(pulls), bool(step), bool(balls), clamp, empty)


def _balls_per_vertex(n: int, a: np.ndarray, w: np.ndarray, b_max: float, d_max: float,
                      bounds: dict, skin: dict, guard: FoldGuard
                      ) -> tuple[bool, np.ndarray | None]:
    r"""The balls' certificate of :func:`certify` vertex by vertex (:func:`_empty_balls`),
    from the activations ``a`` ``(M,)`` and :math:`|W|` ``w`` ``(v,)`` at the active set's
    wrinkled vertices: whether every ball is certified empty, else the ``(n,)`` bool mask of
    those that are (None when none is), with :math:`\Lambda_x = \sum_m a_m
    \mathrm{Lip}_m(x)`, the vertices' separations and the triangles near each vertex
    (:func:`_near_edges`).
    """
    lam_x = (bounds["LipW"] @ a) * (1.0 + 1e-9)
    wrinkled = bounds["wrinkled"]
    ok = _empty_balls(w, skin["near"][wrinkled], lam_x, b_max, d_max, skin, guard,
                      partial(_near_of, bounds, skin["reach"]))
    if ok.all():
        return True, None
    if not ok.any():
        return False, None
    empty = np.zeros(n, bool)
    empty[wrinkled[ok]] = True
    return False, empty


def _empty_balls(w: np.ndarray, sep: np.ndarray, lam: np.ndarray, b_max: float,
                 d_max: float, skin: dict, guard: FoldGuard,
                 near: dict | Callable[[], dict | None] | None) -> np.ndarray:
    r"""``(v,)`` bool: the balls' certificate of :func:`certify` per wrinkled vertex, from
    its :math:`|W|` ``w`` ``(v,)``, rest separation from the other vertices :math:`s_x`
    ``sep`` ``(v,)``, Lipschitz bound :math:`\Lambda_x` ``lam`` ``(v,)`` (of the summed
    pull over the pairs of :math:`x` at most :math:`D` apart) and the triangles near it
    ``near`` (:func:`_near_table`, or a function giving it, called only if a vertex passes
    the other tests). With :math:`\rho_x = |W_x| / (\kappa\eta_d)(1 + 10^{-6})`,
    :math:`\delta_x = 2\rho_x(1 + 10^{-6}) + \tau` and :math:`P = d_{\max} + b_{\max}`:

    * vertices: :math:`\Lambda_x < 1`, :math:`\delta_x \le \min(s_x(1 - \Lambda_x) -
      2b_{\max}, D - 2P)`;
    * triangles not incident to :math:`x`: :math:`\delta_x + 2b_{\max} \le \min_t \max_k
      \min_i (h_{ki} - \Lambda'_x m_i)` over those with :math:`d_{x,t} \le \delta_x + 2P`
      (within the near triangles' reach), :math:`\Lambda'_x = \Lambda_x`, or
      :math:`\max(\Lambda_x, 2P/D)` where a corner lies beyond the pairs; read off the
      table (:func:`_table_bounds`).

    Then no deformed vertex but :math:`x'`, and no point of a deformed triangle not
    incident to :math:`x'`, lies within :math:`2\rho_x` of :math:`x'`, so its ball holds
    none (``docs/model.md``, "Certified skips").
    """
    tau = 1e-12 * (1.0 + skin["size"])
    room = 2.0 * w / (guard.knee * guard.eta_deformed) * (1.0 + 1e-6) * (1.0 + 1e-6) + tau
    P = d_max + b_max
    ok = (lam < 1.0) & (room <= sep * (1.0 - lam) - 2.0 * b_max) \
        & (room <= skin["reach"] - 2.0 * P)
    if not ok.any():
        return ok
    table = near() if callable(near) else near
    if table is None:  # no triangles kept: no vertex is certified for them
        return np.zeros(len(ok), bool)
    far = room + 2.0 * P  # beyond it no point of the skin comes within room of x
    lam_t = np.where(table["far"], np.maximum(lam, 2.0 * P / skin["reach"]), lam)
    ask = np.flatnonzero(ok & (w > 0))  # (a vertex with W = 0 has no ball to search)
    low = _table_bounds(table, lam_t[ask], far[ask], ask)
    ok[ask] &= room[ask] + 2.0 * b_max <= low
    return ok


def _clamp_only(face, state, guard: FoldGuard) -> Certified | None:
    r"""The clamp's certificate alone, for a frame whose pull is not known in closed form
    (refined, or the physical skin's): :math:`|W| \le` :func:`_clamp_limit` at every vertex,
    a refined vertex's limit the least of those of the three nearest vertices of ``face``'s
    skin (whose radii :func:`fold_radii` gives it); where it fails, the vertices that pass
    (``clamp_ok``). None where the skin keeps no bounds.
    """
    skin = getattr(face._rest, "fold_bounds", None)
    if skin is None:
        skin = _skin_bounds(face)
    if not skin:
        return None
    fine = state.face._rest
    limit = getattr(fine, "fold_clamp_limit", None)
    key = (guard.eta, guard.knee)
    if limit is None or limit[0] != key:
        r = skin["radii"]
        base = (1.0 - 1e-5) * guard.knee * guard.eta * np.minimum(r[:, 0], r[:, 1])
        if state.face is face or state.face.skin is face.skin:
            limit = (key, base)
        else:
            limit = (key, _refined_limits(face, state.face, base, key))
        fine.fold_clamp_limit = limit
    ok = np.abs(state.W) <= limit[1]
    clamp = bool(ok.all())
    return Certified(False, False, False, clamp, clamp_ok=None if clamp else ok)


def _refined_limits(face, skin_face, base: np.ndarray, key: tuple) -> np.ndarray:
    r"""``(n,)``: the clamp's limit at each vertex of the refined ``skin_face``, the least of
    ``base`` ``(N,)`` (the limits on ``face``'s skin, for the guard's ``key``) at its three
    nearest vertices of ``face``'s skin (:func:`_nearest_skin_vertices`).

    A refined face is new on nearly every frame of an animation, its vertices rows
    ``order`` of the subdivision hierarchy (its rest frame's ``refined_from``; the rows
    are append-only), so the limits are kept per hierarchy row with ``face``'s rest frame
    (``fold_clamp_rows``: the hierarchy, ``key``, the limits, NaN where not yet found)
    and a frame takes them (one take of ``n``) and finds only the rows no frame asked for.
    """
    src = getattr(skin_face._rest, "refined_from", None)
    if src is None:
        idx = _nearest_skin_vertices(face, skin_face)
        return np.minimum(np.minimum(np.take(base, idx[:, 0]), np.take(base, idx[:, 1])),
                          np.take(base, idx[:, 2]))
    hier, order = src
    memo = getattr(face._rest, "fold_clamp_rows", None)
    rows = memo[2] if memo is not None and memo[0] is hier and memo[1] == key else \
        np.zeros(0)
    if len(rows) < hier.n_points:
        rows = np.concatenate([rows, np.full(hier.n_points - len(rows), np.nan)])
    out = np.take(rows, order)
    todo = np.flatnonzero(np.isnan(out))
    if len(todo):
        idx = np.take(_nearest_skin_vertices(face, skin_face), todo, axis=0)
        out[todo] = np.minimum(np.minimum(np.take(base, idx[:, 0]), np.take(base, idx[:, 1])),
                               np.take(base, idx[:, 2]))
        rows[np.take(order, todo)] = out[todo]
    face._rest.fold_clamp_rows = (hier, key, rows)
    return out


def _measured(state, a: np.ndarray, loose: tuple[float, ...], bounds: dict, skin: dict,
              guard: FoldGuard) -> tuple[bool, bool, bool, float, float]:
    r""":func:`_certificates` with the frame's own pull measured, and the bounds
    :math:`|D| \le` ``d_max`` and :math:`|b| \le` ``b_max`` it used: the slide
    :math:`|p - D|` (``D`` from the kept :math:`U_m` and the activations ``a`` ``(M,)``), the
    gradient bound :math:`\max_t \sum_m a_m \|J_{m,t}\|` and, where the balls' far term
    asks for it, :math:`|D|`; ``loose``: the bounds ``d_max``, ``b_max``, ``lam``,
    ``w_max`` from the per-muscle maxima.
    """
    d_max, b_max, lam, w_max = loose
    moved = bounds["moved"]
    slide = np.take(state.deformed_points, moved, axis=0)
    slide -= np.take(state.rest_points, moved, axis=0)
    D = (bounds["Um"] @ a).reshape(-1, 3)  # the summed tangent pull
    slide -= D
    tol = 1e-12 * (1.0 + skin["size"])
    b_max = min(b_max, math.sqrt(float(np.einsum("ij,ij->i", slide, slide).max())) + tol)
    g = float((bounds["Gt"] @ a).max())
    tight = _certificates(g, d_max, b_max, lam, w_max, bounds, skin, guard)
    if not tight[2]:  # the balls' far term may ask for the measured |D|
        d_max = min(d_max, math.sqrt(float(np.einsum("ij,ij->i", D, D).max())) + tol)
        tight = _certificates(g, d_max, b_max, lam, w_max, bounds, skin, guard)
    return (*tight, d_max, b_max)


def _certificates(g: float, d_max: float, b_max: float, lam: float, w_max: float,
                  bounds: dict, skin: dict, guard: FoldGuard) -> tuple[bool, bool, bool]:
    r"""The pulls', the wrinkle step's and the balls' certificates of :func:`certify` from
    the bounds :math:`\sum_m a_m \|J_{m,t}\|` (``g``, before the slide's part),
    :math:`|D| \le` ``d_max``, :math:`|b| \le` ``b_max``, :math:`\Lambda` (``lam``) and
    :math:`\max|W|` (``w_max``); plain floats (a few microseconds).
    """
    g = (g + _TWO_SQRT2 * bounds["Kp"] * b_max) * (1.0 + 1e-9) + 1e-12
    top = g / guard.knee
    pulls = top < 1.0 and (1.0 - top) ** 2 >= guard.min_area * (1.0 + 1e-9) + 1e-12
    x = g + (_TWO_SQRT2 * bounds["Kw"] * w_max * (1.0 + 1e-9) + 1e-12) / guard.knee_wrinkles
    step = x < 1.0 and (1.0 - x) ** 2 >= guard.min_area_wrinkles * (1.0 + 1e-9) + 1e-12
    room = 2.0 * w_max / (guard.knee * guard.eta_deformed) * (1.0 + 1e-6) * (1.0 + 1e-6) \
        + 1e-12 * (1.0 + skin["size"])  # 2 rho (1 + 1e-6) + tau
    P = d_max + b_max
    far = room + 2.0 * P  # beyond it no point of the skin comes within room of x
    lam = max(lam, 2.0 * P / skin["reach"])  # (a corner beyond the pairs: |p - p'| <= 2P)
    if lam >= 1.0 or far > 0.5 * skin["reach"]:  # (the near triangles' reach)
        return pulls, step, False
    need = room + 2.0 * b_max
    balls = need <= bounds["sep"] * (1.0 - lam)
    # the triangles near the wrinkled vertices (_near_edges, _near_table), found once, by
    table = _near_of(bounds, skin["reach"]) if balls else None  # the first frame that
    if balls and table is not None:  # gets this far: |q' - x'| >= min_i (h_i - lam m_i) - 2b
        low = _table_bounds(table, np.array([lam]), np.array([far]))
        balls = bool(low[0] >= need)
    return pulls, step, balls


_TWO_SQRT2 = 2.0 * math.sqrt(2.0)
