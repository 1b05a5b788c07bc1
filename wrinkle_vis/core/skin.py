r"""The physically based skin: a mass-spring-damper surface bound to the skull (issue 27).

The paper's face (its reference [13]) is a simulated skin whose compression drives the
wrinkles. This module builds that skin beside the geometric one of
:mod:`wrinkle_vis.core.face`, with numpy and scipy only.

Model
-----
The skin surface's vertices carry lumped masses :math:`m_i = \rho\, t\, a_i` (density
:math:`\rho`, tissue thickness :math:`t`, a third of the area :math:`a_i` of the triangles
around the vertex). Its potential energy is

.. math::

    E(x) = \sum_{s} \tfrac12 k_s (l_s - L_s)^2
         + \sum_{e} \tfrac12 r\, k_e \big(l_e - \Pi_e(l_e)\big)^2
         + \sum_i \tfrac12 \kappa a_i |x_i - \bar x_i|^2
         + \sum_i \tfrac12 \kappa_z \omega_i a_i |x_i - \bar x_i - D_i|^2

* springs :math:`s`: every edge (stiffness :math:`k_e = Y a_e / L_e^2`, :math:`Y` the
  membrane stiffness, :math:`a_e` a third of the area of the edge's triangles, so the
  membrane's stiffness does not depend on the mesh) and a *bending spring* across each
  interior edge, between its two opposite vertices (:math:`k_b = B a_e / L_b^2`);
* the *biphasic* branch: past a strain :math:`\pm c` an edge stiffens by a factor
  :math:`1 + r` (:math:`\Pi_e` clamps the length to :math:`[L_e (1 - c), L_e (1 + c)]`);
  the stiff branch is the guard against collapse (an edge compressed by more than
  :math:`c` meets :math:`r` times its soft stiffness);
* attachment springs: each vertex is bound to its rest position :math:`\bar x_i`, at the
  rest tissue depth over the skull, with stiffness :math:`\kappa a_i` per vertex
  (:math:`\kappa` a stiffness per area, of the tissue under the skin);
* muscle (zone) springs: where muscles grip the skin (:math:`\omega_i \in [0, 1]`; 1 on
  every muscle's area of influence, :meth:`FaceModel.muscle_grip`), a spring of
  stiffness :math:`\kappa_z \omega_i a_i` pulls the vertex towards its rest position
  displaced by the muscles, :math:`\bar x_i + D_i`, where :math:`D` is
  :meth:`~wrinkle_vis.core.muscle.Muscle.displacement` summed over the active muscles and
  slid along the skin, exactly as the geometric skin computes it. This is the author's
  "displace the zone, the rest relaxes"; the spring's pull is the force :math:`f_i` of the
  paper's Fig. 2. Prescribed targets rather than free forces keep each muscle's calibrated
  amplitude (its ``strength``) meaningful on both skins, need nothing of a muscle type
  beyond what it declares (so a plug-in type drives this skin with no code of its own), and
  keep the system matrix constant while the activations change.

The skin never enters the skull: after each step a vertex that was outside the skull at rest
and whose signed distance to the skull (to the closest point of its triangles) became
negative is put back on the skull at that point. (Where a scan's skull reaches through its
skin, the vertices inside it at rest are left free.)

Integration
-----------
Implicit Euler with mass-proportional damping :math:`c`, written as a minimisation (Liu et
al. 2013, "Fast simulation of mass-spring systems"; projective dynamics, Bouaziz et al.
2014):

.. math::

    x_{n+1} = \arg\min_x \tfrac{1}{2h^2} \|x - y\|_M^2 + \tfrac{c}{2h} \|x - x_n\|_M^2 + E(x),
    \qquad y = x_n + h v_n .

Each spring's term is :math:`\tfrac12 k |(x_i - x_j) - d|^2` minimised over directions
:math:`d` of the wanted length, so a *local* step projects every spring (its direction at
the current iterate, its wanted length), and a *global* step solves one linear system whose
matrix, :math:`A = (1/h^2 + c/h) M + \sum k\, G^T G + \operatorname{diag}(\kappa a +
\kappa_z \omega a)`, does not change while the activations do, and each step runs a fixed
number of local/global iterations. A still frame is the same minimisation without the
inertial terms, iterated to equilibrium.

Muscle layouts
--------------
Only the zone springs' diagonal :math:`\kappa_z \omega a` depends on the muscle layout
(:math:`\omega`); the springs, masses, attachments, Laplacian :math:`L = \sum k G^T G` and
skull contact depend on the rest skin and material alone and are built once, shared by every
layout of a face (:class:`SpringRest`). For each step :math:`h` (and the still frame) one
layout's matrix :math:`A_b` is factorized (scipy's ``splu``); another layout's matrix
differs from it on the diagonal only, on the :math:`k` vertices :math:`E` whose grip differs
(a muscle drag changes a few: at paper size 0-13 for one forehead muscle moved 6 mm), so

.. math::

    A = A_b + E\, C\, E^T, \quad C = \operatorname{diag}\big(\kappa_z (\omega_E -
    \omega_{b,E})\, a_E\big), \qquad
    A^{-1} b = A_b^{-1} b - W (I + C S)^{-1} C\, E^T A_b^{-1} b,

with :math:`W = A_b^{-1} E` (:math:`k` solves, once per layout) and :math:`S = E^T W`
(Sherman-Morrison-Woodbury, :class:`_GlobalSolve`): exact, one solve with the old factor per
global step, no factorization. When :math:`k` solves would cost more than a factorization
(by the factor's counts), the layout is factorized and becomes :math:`A_b`. A lagged
splitting (:math:`A_b x_{k+1} = b + (A_b - A) x_k`) was not taken: the zone springs are
stiff, :math:`\kappa_z a_i / (L_{ii} + \kappa a_i)` is 13-21 (5th-95th percentile at paper
size), so the splitting diverges at a vertex that enters a zone and contracts by only about
0.94 per iteration at one that leaves it.

A still frame asked for with ``warm_start`` (:meth:`FaceModel.evaluate`; the app does
while a muscle is dragged) starts from the latest still frame of the same activations on any
layout of that face (:meth:`SpringSkin.equilibrium`'s ``warm``): after a drag's small move
it is a few iterations away. Every other still frame starts from the rest skin, so it does
not depend on which frames were asked for before. The answer is the equilibrium to the
solver's tolerance from any start (the tolerance, :math:`10^{-7}` of the skin's size on the
iteration's step, leaves about :math:`1.5 \cdot 10^{-5}` of the size from the exact
minimum from the rest skin and from a warm start alike), so frames of one layout reached
from different starts agree to that accuracy, not bit for bit; one face evaluated again
returns its frame bit for bit.

The muscles' activations follow the commands through first-order activation dynamics
(Zajac 1989), :math:`\dot a = (u - a)/\tau_a`, integrated exactly over each step; with
physiological tissue stiffnesses the skin itself settles within a few milliseconds, so
:math:`\tau_a` sets how fast an expression forms.
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from .mesh import TriangleSurface, barycentric_points, surface_coordinates, unit_rows
from .params import PARAMETER_KEY, Parameter, ParameterValueError, format_value, parameter

__all__ = ["ACTIVATION_TOL", "DEFAULT_SKIN_MODEL", "PHYSICAL_DEFAULT_MAX_POINTS", "SKIN_MODELS",
           "SkinMaterial", "SpringRest", "SpringSkin", "activation_response", "bending_pairs",
           "check_skin_model", "default_skin_model", "default_skin_notice",
           "inverted_triangles", "vertex_areas"]

#: The skin models a face can be evaluated with: the muscles' geometric pulls and the
#: physically based skin of this module.
SKIN_MODELS = ("geometric", "physical")

#: The skin model a face evaluates with when nothing says otherwise (a face built without
#: ``skin_model``, a layout file without one, the command line without ``--skin-model``,
#: the app, sweeps), up to :data:`PHYSICAL_DEFAULT_MAX_POINTS` vertices: the physically
#: based skin, chosen by measurement (README, "Which skin is the default"): it meets every
#: target of issue 27 on both built-in faces. Every layer reads it through
#: :func:`default_skin_model`.
DEFAULT_SKIN_MODEL = "physical"

#: The largest skin (vertices) on which the default is the physical skin: its first frame
#: (factorization and equilibrium, every muscle at 0.7) fits issue 33's budget for a first
#: frame, 10 s and 1 GB, at 60,312 vertices (6.6 s of CPU, 471 MiB) and not at 80,387
#: (11.1 s) (``benchmarks/bench_skin_policy.py``, ``docs/benchmarks.md`` stop 37). A bigger
#: skin defaults to the geometric skin.
PHYSICAL_DEFAULT_MAX_POINTS = 65_000


def default_skin_model(n_points: int) -> str:
    """The skin model of a face of ``n_points`` vertices that names none:
    :data:`DEFAULT_SKIN_MODEL` up to :data:`PHYSICAL_DEFAULT_MAX_POINTS` vertices, the
    geometric skin above (:func:`default_skin_notice` says so in one line).
    """
    if DEFAULT_SKIN_MODEL == "physical" and int(n_points) > PHYSICAL_DEFAULT_MAX_POINTS:
        return "geometric"
    return DEFAULT_SKIN_MODEL


def default_skin_notice(n_points: int) -> str | None:
    """One line for a face of ``n_points`` vertices whose default is not
    :data:`DEFAULT_SKIN_MODEL` (:func:`default_skin_model`), else None.
    """
    model = default_skin_model(n_points)
    if model == DEFAULT_SKIN_MODEL:
        return None
    return (f"the skin has {int(n_points):,} vertices, more than the physical skin's first "
            f"frame fits in 10 s and 1 GB ({PHYSICAL_DEFAULT_MAX_POINTS:,}): it uses the "
            f"{model} skin; --skin-model physical (skin=\"physical\") simulates it anyway")


def check_skin_model(skin: str) -> str:
    """``skin`` if it names a skin model (:data:`SKIN_MODELS`), else a one-line error."""
    if skin not in SKIN_MODELS:
        raise ValueError(f"unknown skin model {skin!r}; choose one of {', '.join(SKIN_MODELS)}")
    return skin


@dataclass(frozen=True)
class SkinMaterial:
    """The physically based skin's material and solver parameters, declared once.

    Every field carries a :class:`~wrinkle_vis.core.params.Parameter` (label, symbol, SI
    unit, range, meaning), which validation, layout files, the app's panel and the docs read
    (:meth:`parameters`, :func:`~wrinkle_vis.core.params.parameter_table`). Defaults and
    their sources are tabulated in ``docs/model.md``.
    """

    membrane_stiffness: float = parameter(
        100.0, label="Y (N/m)", symbol="Y", unit="N/m", lo=0.0, lo_open=True, step=10.0,
        doc="membrane stiffness of the skin (Young's modulus times thickness)")
    bending_stiffness: float = parameter(
        10.0, label="B (N/m)", symbol="B", unit="N/m", lo=0.0, step=1.0,
        doc="stiffness of the bending springs across each interior edge")
    biphasic_strain: float = parameter(
        0.3, label="c", symbol="c", unit="1", lo=0.0, hi=1.0, lo_open=True, hi_open=True,
        step=0.01, doc="strain past which an edge stiffens (biphasic law, guard against "
        "collapse)")
    biphasic_ratio: float = parameter(
        10.0, label="r", symbol="r", unit="1", lo=0.0, step=1.0,
        doc="extra stiffness of the stiff branch, in units of the soft stiffness")
    attachment_stiffness: float = parameter(
        4e5, label="kappa (N/m^3)", symbol="κ", unit="N/m^3", lo=0.0, lo_open=True,
        step=1e4, doc="stiffness per area of the tissue binding the skin to the skull")
    muscle_stiffness: float = parameter(
        1e9, label="kappa_z (N/m^3)", symbol="κ_z", unit="N/m^3", lo=0.0, step=1e5,
        doc="stiffness per area of a muscle's grip on the skin of its zone")
    density: float = parameter(
        1040.0, label="rho (kg/m^3)", symbol="ρ", unit="kg/m^3", lo=0.0, lo_open=True,
        step=10.0, doc="density of the soft tissue")
    thickness: float = parameter(
        0.008, label="t (m)", symbol="t", unit="m", lo=0.0, lo_open=True, step=0.001,
        doc="thickness of soft tissue moving with the skin (lumped mass per area rho t)")
    damping: float = parameter(
        20.0, label="c_d (1/s)", symbol="c_d", unit="1/s", lo=0.0, step=1.0,
        doc="mass-proportional damping")
    activation_time: float = parameter(
        0.045, label="tau_a (s)", symbol="τ_a", unit="s", lo=0.0, step=0.005,
        doc="time constant of the muscles' activation dynamics")
    time_step: float = parameter(
        1.0 / 30.0, label="h (s)", symbol="h", unit="s", lo=0.0, lo_open=True, step=0.001,
        doc="default time step of a simulation")
    iterations: int = parameter(
        10, label="iterations", symbol="N", unit="count", lo=1, step=1,
        doc="local/global iterations per time step")

    def __post_init__(self):
        for p in self.parameters():  # the muscles' check (Parameter.validate), one message
            value = getattr(self, p.name)
            try:
                object.__setattr__(self, p.name, p.validate(value))
            except ParameterValueError as e:
                where = "outside" if e.allowed[0] in "([" else "not"
                allowed = e.allowed + (f", {e.hint}" if e.hint else "")
                raise ValueError(f"skin {p.name} = {format_value(value)} is {where} "
                                 f"{allowed}; {p.doc}") from None

    @classmethod
    def parameters(cls) -> tuple[Parameter, ...]:
        """Every parameter with its metadata, in declaration order."""
        return tuple(dataclasses.replace(f.metadata[PARAMETER_KEY], name=f.name)
                     for f in dataclasses.fields(cls))

    def to_dict(self) -> dict:
        """A plain, JSON-ready dict of the parameters."""
        return {p.name: getattr(self, p.name) for p in self.parameters()}

    @classmethod
    def from_dict(cls, data) -> SkinMaterial:
        """The material from :meth:`to_dict` output; unknown keys are an error."""
        names = {p.name for p in cls.parameters()}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValueError(f"unknown skin parameter(s) {', '.join(unknown)}; known: "
                             f"{', '.join(sorted(names))}")
        return cls(**dict(data))


def vertex_areas(skin: TriangleSurface) -> np.ndarray:
    """``(n,)``: a third of the area of the triangles around each vertex."""
    area = np.repeat(skin.triangle_areas() / 3.0, 3)
    return np.bincount(skin.triangles.ravel(), weights=area, minlength=skin.n_points)


def bending_pairs(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bending springs: for each interior edge, its two opposite vertices.

    Parameters
    ----------
    triangles : (m, 3) int

    Returns
    -------
    pairs : (b, 2) int
        The opposite vertices of each interior edge.
    tris : (b, 2) int
        The two triangles of each interior edge.
    """
    t = np.asarray(triangles, dtype=np.int64)
    m = len(t)
    a = t[:, [0, 1, 2]].ravel()
    b = t[:, [1, 2, 0]].ravel()
    opp = t[:, [2, 0, 1]].ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * (int(t.max(initial=0)) + 1) + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    first, second = order[same], order[same + 1]
    tri = np.arange(m).repeat(3)
    return (np.stack([opp[first], opp[second]], axis=1),
            np.stack([tri[first], tri[second]], axis=1))


def inverted_triangles(rest: np.ndarray, points: np.ndarray, triangles: np.ndarray) -> int:
    """How many ``triangles`` ``(m, 3)`` turned over: their normal at ``points`` ``(n, 3)``
    points against their normal at ``rest`` (or they collapsed to no area).
    """
    def normals(p):
        a, b, c = (p[triangles[:, k]] for k in range(3))
        return np.cross(b - a, c - a)

    return int(np.count_nonzero(np.einsum("ij,ij->i", normals(rest), normals(points)) <= 0))


def _pseudo_normals(surface: TriangleSurface):
    r"""The angle-weighted pseudo-normals of a closed ``surface`` (Bærentzen and Aanæs
    2005), as a function ``(tri, bary) -> (k, 3)``: at a closest point with barycentric
    coordinates ``bary`` ``(k, 3)`` in triangles ``tri`` ``(k,)``, the triangle's normal
    inside it, the sum of the two triangles' unit normals on an edge, and
    :math:`\sum_t \theta_t \hat n_t` (the corner angles) at a vertex. The sign of
    :math:`(x - c) \cdot n` is then the side of ``x``, exactly: the vertex normals
    interpolated across a triangle can point the other way from its own normal, and call
    a point in front of the triangle inside.
    """
    t = surface.triangles
    p = surface.points[t]  # (m, 3, 3)
    face = unit_rows(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))
    edge = np.zeros((len(surface.edges), 3))
    np.add.at(edge, surface.triangle_edges.ravel(), np.repeat(face, 3, axis=0))
    vertex = np.zeros((surface.n_points, 3))
    for k in range(3):
        a, b = p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]
        cos = np.einsum("ij,ij->i", unit_rows(a), unit_rows(b))
        np.add.at(vertex, t[:, k], np.arccos(np.clip(cos, -1.0, 1.0))[:, None] * face)
    eps = 1e-9

    def at(tri: np.ndarray, bary: np.ndarray) -> np.ndarray:
        zero = bary <= eps
        count = zero.sum(axis=1)
        out = face[tri].copy()
        on_edge = np.flatnonzero(count == 1)  # the edge opposite the zero corner j: (j+1) % 3
        j = np.argmax(zero[on_edge], axis=1)
        out[on_edge] = edge[surface.triangle_edges[tri[on_edge], (j + 1) % 3]]
        on_vertex = np.flatnonzero(count >= 2)
        k = np.argmax(~zero[on_vertex], axis=1)
        out[on_vertex] = vertex[t[tri[on_vertex], k]]
        return out

    return at


class _Skull:
    r"""The skull as a constraint.

    The signed distance of a point :math:`x` is :math:`s(x) = |x - c|\,\operatorname{sign}
    ((x - c) \cdot n_c)`, :math:`c` the closest point of the whole skull
    (:func:`~wrinkle_vis.core.mesh.surface_coordinates` with ``exact=True``: the sign is
    right only at the true closest point) and :math:`n_c` the skull's pseudo-normal there
    (:func:`_pseudo_normals`: the triangle's own normal inside it, the edge's or the
    vertex's on them). A vertex outside the skull at rest is kept at :math:`s \ge 0`; one
    inside it at rest (where a scan's skull reaches through its skin) is left free.
    """

    #: How close, in skull edges by the nearest-vertex estimate (:meth:`rough`), a point
    #: must come to the skull to be measured exactly.
    NEAR = 1.0

    def __init__(self, skull: TriangleSurface, rest: np.ndarray):
        self.surface = skull
        self.rest = rest
        self.normals = skull.vertex_normals()
        self.pseudo = _pseudo_normals(skull)
        self.tree = cKDTree(skull.points)
        self.margin = self.NEAR * float(np.mean(skull.rest_edge_lengths))
        #: the estimate at rest (which vertices to look at) and, filled in the first time a
        #: vertex is looked at closely, the exact rest distance its floor comes from
        self.rest_rough = self.rough(rest)
        self._rest_exact = np.full(len(rest), np.nan)

    def rough(self, x: np.ndarray) -> np.ndarray:
        """``(k,)``: the signed distance of ``x`` ``(k, 3)`` estimated from the nearest skull
        vertex and its normal (vectorized; off by up to a few skull edges in concave
        places, so it only decides which points to look at closely).
        """
        _, k = self.tree.query(x)
        return np.einsum("ij,ij->i", x - self.surface.points[k], self.normals[k])

    def floor(self, ids: np.ndarray) -> np.ndarray:
        """``(k,)``: the least signed distance vertices ``ids`` may keep: 0 for a vertex
        outside the skull at rest, and no bound (``-inf``) for one inside it at rest (where
        a scan's skull reaches through its skin the side of the skull is ambiguous, and
        pushing such vertices out would tear the skin). Measured the first time asked.
        """
        todo = ids[np.isnan(self._rest_exact[ids])]
        if len(todo):
            self._rest_exact[todo] = self.distance(self.rest[todo])[0]
        return np.where(self._rest_exact[ids] >= 0.0, 0.0, -np.inf)

    def distance(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(k,)`` signed distances of ``x`` ``(k, 3)``, ``(k, 3)`` closest skull points and
        ``(k, 3)`` the skull's unit normals there.
        """
        tri, bary = surface_coordinates(self.surface, x, exact=True)
        c = barycentric_points(self.surface, tri, bary)
        n = unit_rows(np.einsum("kj,kjd->kd", bary, self.normals[self.surface.triangles[tri]]))
        d = x - c
        side = np.einsum("ij,ij->i", d, self.pseudo(tri, bary))
        return np.sqrt(np.einsum("ij,ij->i", d, d)) * np.sign(side), c, n

    def project(self, x: np.ndarray) -> np.ndarray:
        """Put the vertices of ``x`` ``(n, 3)`` that entered the skull back on it (at the
        closest point), in place; returns their ids.
        Only vertices that moved by more than half their estimated rest distance, and that
        the estimate :meth:`rough` puts within :attr:`NEAR` skull edges of the skull, are
        looked at; a vertex found inside the skull at rest is free and never looked at
        again.
        """
        d = x - self.rest
        near = np.flatnonzero(np.einsum("ij,ij->i", d, d)
                              >= (0.5 * np.maximum(self.rest_rough, 0.0)) ** 2)
        near = near[~(self._rest_exact[near] < 0.0)]  # inside at rest (measured): free
        if len(near):
            rough = self.rough(x[near])
            near = near[rough < self.margin]
        if not len(near):
            return near
        s, c, n = self.distance(x[near])
        deep = s < self.floor(near)
        ids = near[deep]
        x[ids] = c[deep]
        return ids


class _GlobalSolve:
    r"""The global step's solve :math:`x = A^{-1} b` for one layout's matrix
    :math:`A = A_b + E\,C\,E^T`: a factorized matrix :math:`A_b` (another layout's) plus the
    diagonal change :math:`C` ``(k,)`` on the ``k`` vertices :math:`E` where the two
    layouts' diagonals differ (Sherman-Morrison-Woodbury):

    .. math::

        A^{-1} b = y - W (I + C S)^{-1} C\, y_E, \qquad y = A_b^{-1} b,\;
        W = A_b^{-1} E,\; S = E^T W,

    :math:`W` ``(n, k)`` computed once (``k`` solves with :math:`A_b`'s factor), so a
    solve costs one solve with :math:`A_b`, a ``k x k`` solve and an ``n x k`` product.
    Exact up to rounding: :math:`A` and :math:`A_b` are both symmetric positive definite,
    and :math:`I + C S` is invertible whenever they are.
    """

    #: Right-hand sides per call of the factor's solve when :math:`W` is built: SuperLU's
    #: solve of a few columns at a time is several times faster per column than of many.
    BATCH = 4

    def __init__(self, lu, ids: np.ndarray | None = None, change: np.ndarray | None = None):
        self.lu = lu
        self.ids = np.zeros(0, np.intp) if ids is None else np.asarray(ids, dtype=np.intp)
        if not len(self.ids):
            return
        n, k = lu.shape[0], len(self.ids)
        w = np.empty((n, k), order="F")
        for start in range(0, k, self.BATCH):
            cols = np.arange(start, min(start + self.BATCH, k))
            unit = np.zeros((n, len(cols)), order="F")
            unit[self.ids[cols], np.arange(len(cols))] = 1.0
            w[:, cols] = lu.solve(unit)
        self.w, self.change = w, np.asarray(change, dtype=float)
        # (I + C S)^-1 C, k x k: inverted once (numpy's LAPACK; scipy's would start a
        # thread pool that SuperLU's BLAS calls then spin on)
        self.capacitance = np.linalg.solve(np.eye(k) + self.change[:, None] * w[self.ids],
                                           np.diag(self.change))

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``(n, c)``: :math:`A^{-1} b` for ``b`` ``(n, c)`` (Fortran-ordered is fastest)."""
        y = self.lu.solve(b)
        if len(self.ids):
            z = np.einsum("ij,jc->ic", self.capacitance, y[self.ids])
            # einsum, not BLAS: OpenBLAS threads a product this thin and, on a busy
            # machine, spins for far longer than it computes
            y -= np.einsum("nk,kc->nc", self.w, z)
        return y


class SpringRest:
    r"""What the spring skin of one rest surface, material and length unit holds whatever
    the muscle layout: the springs, the masses, the attachments, the Laplacian
    :math:`L = \sum_s k_s G_s^T G_s`, the skull contact, the global matrices' factors and
    the latest still frames. One is shared by every :class:`SpringSkin` of a face and the
    faces derived from it (:meth:`~wrinkle_vis.core.face.FaceModel.with_muscle` and the
    like), so a new layout builds none of it again.

    Parameters
    ----------
    skin : TriangleSurface
        The rest skin.
    material : SkinMaterial
    metres_per_unit : float
        The face's length unit in metres.
    skull : TriangleSurface, optional
        The skull the skin stays out of.
    contact : _Skull, optional
        The skull contact of ``skull`` on ``skin``, when one is built already.
    """

    #: Still frames kept for warm starts (:meth:`SpringSkin.equilibrium`'s ``warm``).
    WARM_STARTS = 8

    def __init__(self, skin: TriangleSurface, material: SkinMaterial,
                 metres_per_unit: float = 1e-3, skull: TriangleSurface | None = None,
                 contact: _Skull | None = None):
        self.material = mat = material
        self.rest = np.ascontiguousarray(skin.points, dtype=float)
        n = self.n = skin.n_points
        # (n,) vertex areas in face units^2 and the unit's square: every per-area term is
        # (parameter * area) * s2, in that order, as before the layouts shared this object
        self.area, self.s2 = vertex_areas(skin), float(metres_per_unit) ** 2
        self.mass = mat.density * mat.thickness * self.area * self.s2
        self.k_att = mat.attachment_stiffness * self.area * self.s2
        self.i, self.j, self.L, self.k, self.n_edges = _spring_network(skin, mat)
        self.kb = mat.biphasic_ratio * self.k[: self.n_edges]
        self.kL = self.k * self.L
        # what the local step reads every iteration and never changes: the biphasic clamp's
        # bounds
        c, rest_len = mat.biphasic_strain, self.L[: self.n_edges]
        self._clamp_lo, self._clamp_hi = rest_len * (1.0 - c), rest_len * (1.0 + c)
        self.k_total = self.k.copy()
        self.k_total[: self.n_edges] += self.kb
        s = len(self.L)
        self.J = sp.csr_matrix((np.concatenate([np.ones(s), -np.ones(s)]),
                                (np.concatenate([self.i, self.j]), np.tile(np.arange(s), 2))),
                               shape=(n, s))
        self.laplacian = (self.J @ sp.diags(self.k_total) @ self.J.T).tocsc()
        if contact is None and skull is not None:
            contact = _Skull(skull, self.rest)
        self.skull = contact
        self.diameter = float(np.linalg.norm(self.rest.max(axis=0) - self.rest.min(axis=0)))
        #: how many global matrices were factorized (a new layout normally adds none)
        self.factorizations = 0
        self._bases: dict[float | None, tuple[np.ndarray, object, float, float]] = {}
        self._warm: OrderedDict = OrderedDict()
        self._lock = threading.Lock()  # faces of one family may be evaluated on two threads

    def diagonal(self, anchor: np.ndarray, h: float | None) -> np.ndarray:
        r"""``(n,)``: the global matrix's diagonal term for the springs' ``anchor``
        ``(n,)`` (:math:`\kappa a + \kappa_z \omega a`) and step ``h`` (None: the still
        frame): ``anchor`` plus :math:`(1/h^2 + c/h)\, m`.
        """
        if h is None:
            return anchor
        return anchor + self.mass * (1.0 / h**2 + self.material.damping / h)

    def solver(self, anchor: np.ndarray, h: float | None) -> _GlobalSolve:
        r"""The global solve of the layout whose anchors are ``anchor`` ``(n,)``, for step
        ``h`` (None: the still frame).

        The latest factorized matrix for ``h`` (the *base*) serves every layout whose
        diagonal differs from it on few enough vertices (:class:`_GlobalSolve`, exact);
        otherwise the layout's own matrix is factorized and becomes the base. Few enough:
        ``k`` solves cost less than a factorization, by the factor's counts (``k`` times
        :math:`\operatorname{nnz}(L) + \operatorname{nnz}(U)` against
        :math:`\sum_j c_j^2`, :math:`c_j` the entries of the factor's column :math:`j`).
        """
        diag = self.diagonal(anchor, h)
        with self._lock:
            base = self._bases.get(h)
            if base is not None:
                base_diag, lu, solve_cost, factor_cost = base
                ids = np.flatnonzero(diag != base_diag)
                if len(ids) * solve_cost <= factor_cost:
                    return _GlobalSolve(lu, ids, diag[ids] - base_diag[ids])
            lu = self._factorize(diag)
            low = lu.L.tocsc()
            counts = np.diff(low.indptr).astype(float)
            if len(self._bases) > 4:
                self._bases.clear()
            self._bases[h] = (diag.copy(), lu, float(low.nnz + lu.U.nnz),
                              float(np.dot(counts, counts)))
        return _GlobalSolve(lu)

    def _factorize(self, diag: np.ndarray):
        r"""The sparse LU factor of :math:`L + \operatorname{diag}(` ``diag`` ``)``."""
        self.factorizations += 1
        mat = (self.laplacian + sp.diags(diag)).tocsc()
        # symmetric mode: the pivots stay on the diagonal of this SPD matrix and the
        # ordering of A + A^T keeps the fill of a Cholesky factor
        return spla.splu(mat, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                         options={"SymmetricMode": True})

    def warm_start(self, key) -> np.ndarray | None:
        """The latest still frame stored under ``key`` by any layout, or None."""
        with self._lock:
            x = self._warm.get(key)
            if x is not None:
                self._warm.move_to_end(key)
            return x

    def keep_warm(self, key, x: np.ndarray) -> None:
        """Store the still frame ``x`` ``(n, 3)`` under ``key`` for later warm starts."""
        with self._lock:
            self._warm[key] = x
            self._warm.move_to_end(key)
            while len(self._warm) > self.WARM_STARTS:
                self._warm.popitem(last=False)


class SpringSkin:
    r"""The mass-spring skin of one rest surface, one muscle grip and one material.

    Parameters
    ----------
    skin : TriangleSurface
        The rest skin.
    grip : (n,) float
        :math:`\omega_i \in [0, 1]`: how strongly the muscles hold each vertex.
    material : SkinMaterial
    metres_per_unit : float
        The face's length unit in metres (masses and the per-area stiffnesses are SI).
    skull : TriangleSurface, optional
        The skull the skin stays out of.
    shared : SpringRest, optional
        What does not depend on the grip, when another layout of the same rest skin,
        material, unit and skull has built it (:class:`SpringRest`): then ``skin``,
        ``metres_per_unit`` and ``skull`` are read from it.

    Notes
    -----
    The object holds what depends on the grip (the zone springs, the global solves); the
    rest is :attr:`shared`. A state, positions and velocities ``(x, v)``, is passed in and
    out (:class:`~wrinkle_vis.core.simulation.Simulation` keeps one).
    """

    def __init__(self, skin: TriangleSurface, grip: np.ndarray, material: SkinMaterial,
                 metres_per_unit: float = 1e-3, skull: TriangleSurface | None = None, *,
                 shared: SpringRest | None = None):
        if shared is None:
            shared = SpringRest(skin, material, metres_per_unit, skull)
        elif shared.material != material:
            raise ValueError("the shared spring data is of another material; build a "
                             "SpringRest for this one")
        self.shared = rest = shared
        self.material = material
        self.grip = np.clip(np.asarray(grip, dtype=float), 0.0, 1.0)
        self.rest, self.n, self.mass, self.k_att = rest.rest, rest.n, rest.mass, rest.k_att
        self.i, self.j, self.L, self.k, self.n_edges = rest.i, rest.j, rest.L, rest.k, \
            rest.n_edges
        self.kb, self.kL, self.k_total = rest.kb, rest.kL, rest.k_total
        self._clamp_lo, self._clamp_hi = rest._clamp_lo, rest._clamp_hi
        self.J, self.laplacian, self.skull = rest.J, rest.laplacian, rest.skull
        self.k_zone = material.muscle_stiffness * self.grip * rest.area * rest.s2
        self.anchor = self.k_att + self.k_zone
        # the attachments' pull towards the rest skin, read by every solve
        self._anchor_rest = self.anchor[:, None] * self.rest
        self._factors: dict[float | None, _GlobalSolve] = {}
        self._still: tuple | None = None  # (warm key, pull, still frame, cold?) of the latest

    def size(self) -> float:
        """The length of the rest skin's bounding-box diagonal (face units)."""
        return self.shared.diameter

    def _factor(self, h: float | None) -> _GlobalSolve:
        """The global solve for step ``h`` (None: the still frame), from
        :meth:`SpringRest.solver`.
        """
        solve = self._factors.get(h)
        if solve is None:
            if len(self._factors) > 4:
                self._factors.clear()
            solve = self._factors[h] = self.shared.solver(self.anchor, h)
        return solve

    def spring_targets(self, x: np.ndarray) -> np.ndarray:
        r"""``(n, 3)``: the local step's right-hand side :math:`\sum_s k_s G_s^T d_s` of
        the springs projected at ``x`` ``(n, 3)``: each spring's current direction times
        :math:`k L + r k_e \Pi_e(l)` (the biphasic clamp on the edges). Works on the
        coordinate rows (per-component gathers and one sparse scatter each); the result is
        Fortran-ordered, as the factorized solve wants it.
        """
        xt = np.asarray(x).T
        d = np.empty((3, len(self.L)))
        for axis in range(3):
            row = np.ascontiguousarray(xt[axis])
            np.subtract(row.take(self.i), row.take(self.j), out=d[axis])
        length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        ne = self.n_edges
        wanted = np.empty_like(length)  # k L, plus r k_e Pi_e(l) on the edges
        np.clip(length[:ne], self._clamp_lo, self._clamp_hi, out=wanted[:ne])
        wanted[:ne] *= self.kb
        wanted[:ne] += self.kL[:ne]
        wanted[ne:] = self.kL[ne:]
        np.maximum(length, 1e-300, out=length)
        wanted /= length
        d *= wanted
        out = np.empty((3, self.n))
        for c in range(3):
            out[c] = self.J @ d[c]
        return out.T

    def _anchor_rhs(self, target_disp: np.ndarray) -> np.ndarray:
        """``(n, 3)``: the attachment and zone springs' pull on the right-hand side."""
        return self._anchor_rest + self.k_zone[:, None] * target_disp

    def step(self, x: np.ndarray, v: np.ndarray, target_disp: np.ndarray,
             h: float) -> tuple[np.ndarray, np.ndarray]:
        r"""The state ``(x, v)`` (``(n, 3)`` each) after ``h`` seconds with the muscles'
        displacement ``target_disp`` ``(n, 3)`` (:math:`D`): implicit Euler by a fixed
        number of local/global iterations, then the skull projection.

        Returns
        -------
        x, v : (n, 3) float
            New positions and velocities :math:`(x_{n+1} - x_n) / h`.
        """
        h = float(h)
        solve = self._factor(h)
        mat = self.material
        y = x + h * v
        fixed = (self.mass * (1.0 / h**2))[:, None] * y
        fixed += (self.mass * (mat.damping / h))[:, None] * x
        fixed += self._anchor_rhs(target_disp)
        fixed = np.asfortranarray(fixed)
        new = x
        for _ in range(mat.iterations):
            new = solve.solve(fixed + self.spring_targets(new))
        if self.skull is not None:
            self.skull.project(new)
        return new, (new - x) / h

    def equilibrium(self, target_disp: np.ndarray, x: np.ndarray | None = None, *,
                    tol: float = 1e-7, max_iter: int = 500, window: int = 5,
                    warm=None, start_warm: bool = True) -> np.ndarray:
        """``(n, 3)``: the still frame, the minimum of :math:`E` for ``target_disp``
        ``(n, 3)``, from ``x`` (default the rest skin): local/global iterations, sped up by
        Anderson acceleration over the last ``window`` iterates (Peng et al. 2018), until no
        vertex moves by more than ``tol`` times the skin's size. With no pull and no start
        given the answer is the rest skin itself (every term of :math:`E` vanishes there),
        returned exactly rather than through a solve's rounding.

        ``warm`` (hashable, optional) names what is solved for (a face passes its resolved
        activations); the answer is kept under that name for later warm starts. With
        ``start_warm`` and without ``x``, the solve starts from the latest still frame kept
        under that name by any layout sharing :attr:`shared` (a dragged muscle's new layout
        starts from the old layout's frame, a few iterations away); the answer is the
        equilibrium to the same tolerance from any start, not bit for bit. Without
        ``start_warm`` it starts from the rest skin, so the answer depends on the skin and
        ``target_disp`` alone. This skin asked again with the same name and pull returns its
        answer again, bit for bit (a warm-started answer only to a warm request).
        """
        if x is None and not np.any(target_disp):
            return self.rest.copy()
        if warm is not None and x is None:
            still = self._still
            if still is not None and still[0] == warm and (start_warm or still[3]) \
                    and np.array_equal(still[1], target_disp):
                return still[2].copy()
            if start_warm:
                x = self.shared.warm_start(warm)
        solve = self._factor(None)
        fixed = np.asfortranarray(self._anchor_rhs(target_disp))

        def g(y):
            y = y.reshape((self.n, 3), order="F")
            return solve.solve(fixed + self.spring_targets(y)).ravel(order="F")

        x0 = self.rest if x is None else np.asarray(x, dtype=float)
        out = _anderson(g, x0.ravel(order="F"), tol * self.size(), max_iter, window)
        out = out.reshape((self.n, 3), order="F").copy()
        if self.skull is not None:
            self.skull.project(out)
        if warm is not None:
            self._still = (warm, np.array(target_disp, dtype=float), out.copy(), x is None)
            self.shared.keep_warm(warm, self._still[2])
        return out

    def energy(self, x: np.ndarray, v: np.ndarray, target_disp: np.ndarray | None = None
               ) -> float:
        r"""Kinetic plus potential energy :math:`\tfrac12 v^T M v + E(x)` of the state
        ``(x, v)`` (``(n, 3)`` each; lengths in the face's units).
        """
        d = x[self.i] - x[self.j]
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        ne = self.n_edges
        e = 0.5 * (self.k * (length - self.L) ** 2).sum()
        clamp = np.clip(length[:ne], self._clamp_lo, self._clamp_hi)
        e += 0.5 * (self.kb * (length[:ne] - clamp) ** 2).sum()
        u = x - self.rest
        e += 0.5 * (self.k_att * np.einsum("ij,ij->i", u, u)).sum()
        if target_disp is not None:
            u = u - target_disp
        e += 0.5 * (self.k_zone * np.einsum("ij,ij->i", u, u)).sum()
        return float(e + 0.5 * (self.mass * np.einsum("ij,ij->i", v, v)).sum())


def _anderson(g, x: np.ndarray, tol: float, max_iter: int, window: int) -> np.ndarray:
    r"""A fixed point of ``g`` from ``x`` ``(k,)`` by Anderson acceleration (type II):
    :math:`x_{k+1} = g(x_k) - \Delta G\, \gamma`, :math:`\gamma` the least-squares fit of
    the residual :math:`f_k = g(x_k) - x_k` by the last ``window`` residual differences
    :math:`\Delta F`; the history restarts when the residual grows. Stops when
    :math:`\max |f_k| \le` ``tol``.

    The normal equations :math:`\Delta F^T \Delta F\, \gamma = \Delta F^T f_k` are kept up
    to date one difference at a time, and every product is numpy's own loop, not BLAS:
    OpenBLAS threads products of this shape and, on a busy machine, its threads spin for
    longer than the products take (a 20k-face drag step cost twice the CPU time).
    """
    gx = g(x)
    f = gx - x
    dgs: list[np.ndarray] = []
    dfs: list[np.ndarray] = []
    gram = np.zeros((window, window))  # dfs[i] . dfs[j]
    best = np.abs(f).max()
    for _ in range(max_iter):
        if np.abs(f).max() <= tol:
            return gx
        m = len(dfs)
        x_new = gx
        if m:
            normal = gram[:m, :m].copy()  # the small normal equations, lightly regularised
            normal[np.diag_indices(m)] += 1e-10 * np.trace(normal) + 1e-300
            gamma = np.linalg.solve(normal, np.array([_dot(d, f) for d in dfs]))
            x_new = gx.copy()
            for c, dg in zip(gamma, dgs, strict=True):
                x_new -= c * dg
        g_new = g(x_new)
        f_new = g_new - x_new
        res = np.abs(f_new).max()
        if res > 10.0 * best:  # accelerating went astray: plain step, forget the history
            dgs.clear()
            dfs.clear()
            x_new, g_new = gx, g(gx)
            f_new = g_new - x_new
            res = np.abs(f_new).max()
        else:
            if m == window:
                dgs.pop(0)
                dfs.pop(0)
                gram[: m - 1, : m - 1] = gram[1:m, 1:m].copy()
            dgs.append(g_new - gx)
            dfs.append(f_new - f)
            k = len(dfs) - 1
            for i, d in enumerate(dfs):
                gram[i, k] = gram[k, i] = _dot(d, dfs[k])
        best = min(best, res)
        x, gx, f = x_new, g_new, f_new
    return gx


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    r""":math:`a \cdot b` of two ``(k,)`` vectors by numpy's own loop (no BLAS threads)."""
    return float(np.einsum("i,i->", a, b))


def _spring_network(skin: TriangleSurface, mat: SkinMaterial):
    r"""The springs of ``skin``: its edges first, then one bending spring across each
    interior edge.

    Returns
    -------
    i, j : (s,) int
        The ends of each spring.
    rest_length : (s,) float
    stiffness : (s,) float
        :math:`Y a_e / L_e^2` on an edge, :math:`B a_e / L_b^2` on a bending spring
        (:math:`a_e` a third of the area of the edge's triangles).
    n_edges : int
        How many of the springs are edges.
    """
    edges, points = skin.edges, skin.points
    tri_area = skin.triangle_areas()
    e_area = np.zeros(len(edges))
    tri_edges = skin.triangle_edges
    np.add.at(e_area, tri_edges.ravel(), np.repeat(tri_area / 3.0, 3))
    rest_len = skin.rest_edge_lengths
    pairs, tris = bending_pairs(skin.triangles)
    b_len = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    b_area = tri_area[tris].sum(axis=1) / 3.0
    i = np.concatenate([edges[:, 0], pairs[:, 0]]).astype(np.intp)
    j = np.concatenate([edges[:, 1], pairs[:, 1]]).astype(np.intp)
    stiffness = np.concatenate([mat.membrane_stiffness * e_area / rest_len**2,
                                mat.bending_stiffness * b_area / np.maximum(b_len, 1e-300)**2])
    return i, j, np.concatenate([rest_len, b_len]), stiffness, len(edges)


#: How close (in activation, of 1) a filtered activation comes to its command before it
#: is set to it: first-order dynamics only approach the command, so without this a
#: released muscle would stay active (and keep its zone off the rest skin) for ever. With
#: the default :math:`\tau_a` the snap comes :math:`\tau_a \ln 10^4 \approx 0.41` s
#: after a full step, and moves the skin by at most 1e-4 of a muscle's full pull.
ACTIVATION_TOL = 1e-4


def activation_response(previous: np.ndarray, command: np.ndarray, h: float,
                        tau: float) -> np.ndarray:
    r"""The activations after ``h`` seconds of first-order activation dynamics,
    :math:`a + (u - a)(1 - e^{-h/\tau_a})` (exact for a command held over the step;
    :math:`\tau_a = 0` follows the command at once); an activation within
    :data:`ACTIVATION_TOL` of its command becomes the command exactly (a released muscle
    reaches 0 and stops pulling).
    """
    command = np.asarray(command, dtype=float)
    if tau <= 0.0:
        return command.copy()
    out = command + (np.asarray(previous, dtype=float) - command) * math.exp(-h / tau)
    near = np.abs(out - command) <= ACTIVATION_TOL
    out[near] = command[near]
    return out
