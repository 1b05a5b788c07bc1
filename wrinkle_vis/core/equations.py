r"""The equations of Zhang, Sim and Tan, "Simulating Wrinkles in Facial Expressions on an
Anatomy-Based Face", as vectorized numpy functions.

Every function carries the equation it implements and its number in the paper. Where this
module deviates from the paper it says so in the function's notes (``compression`` weights
by :math:`|\cos\theta_{ij}|`; ``anisotropy`` clamps :math:`\varepsilon` at 1).
``gradient_compression`` is not the paper's: it is the alternative to Eq. 10 that a muscle's
``compression="gradient"`` option selects (``docs/model.md``, "Two options, off by default").
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .mesh import vector_lengths

__all__ = [
    "anisotropy",
    "attenuation",
    "bulge_height",
    "compression",
    "compression_operator",
    "edge_shrinkage",
    "gradient_compression",
    "gradient_compression_operator",
    "half_period",
    "periodic_coordinate",
    "shape_function",
    "stretch_coefficients",
    "triangle_stretch",
]


def bulge_height(k0: float, alpha: float) -> float:
    r"""Bulge height :math:`d` that makes the shape function volume-preserving (Eq. 8).

    Parameters
    ----------
    k0 : float
        Furrow depth factor :math:`k_0`.
    alpha : float
        Shape modulation factor :math:`\alpha`.

    Returns
    -------
    float
        :math:`d` such that :math:`\int_0^{2u} H(w)\,dw = 0` (Eq. 8), in closed form

        .. math::

            d = k_0 \frac{2^{\alpha + 1} - 1}{2(\alpha + 1)}, \qquad
            d = k_0 \frac{\ln 2}{2} \text{ at } \alpha = -1 .

    Notes
    -----
    With :math:`t = (w - u)/u`, Eq. 5 is :math:`H = d - k_0 (1 + t^2)^\alpha |t|`, so Eq. 8
    reads :math:`2d = 2 k_0 \int_0^1 (1 + t^2)^\alpha t\,dt`. :math:`d` does not depend on
    :math:`u`.
    """
    k0 = float(k0)
    alpha = float(alpha)
    if np.isclose(alpha, -1.0, rtol=0.0, atol=1e-12):
        return k0 * np.log(2.0) / 2.0
    return k0 * (2.0 ** (alpha + 1.0) - 1.0) / (2.0 * (alpha + 1.0))


def shape_function(w, u: float, k0: float, alpha: float) -> np.ndarray:
    r"""Cross-sectional wrinkle shape :math:`H(w)` (Eq. 5).

    Parameters
    ----------
    w : (...) array_like
        Periodic coordinate in :math:`[0, 2u]` (Eq. 7).
    u : float
        Half period :math:`u > 0` (Eq. 6).
    k0, alpha : float
        Furrow depth factor and shape modulation factor.

    Returns
    -------
    (...) ndarray
        .. math::

            H(w) = \begin{cases}
              k_0 \left(1 + t^2\right)^\alpha t + d & 0 \le w \le u \\
             -k_0 \left(1 + t^2\right)^\alpha t + d & u < w \le 2u
            \end{cases}, \qquad t = \frac{w - u}{u},

        with :math:`d` from :func:`bulge_height` (Eq. 8). The crest :math:`H(u) = d` is the
        bulge and :math:`H(0) = H(2u) = d - k_0 2^\alpha` the furrow bottom. ``nan`` in ``w``
        stays ``nan``.
    """
    w = np.asarray(w, dtype=float)
    t = (w - u) / u
    return bulge_height(k0, alpha) - k0 * (1.0 + t * t) ** alpha * np.abs(t)


def half_period(lambda_w: float, length: float, n_wrinkles: int) -> float:
    r"""Half cycling length :math:`u` of the wrinkles (Eq. 6).

    Parameters
    ----------
    lambda_w : float
        Wrinkling-region factor :math:`\lambda_w \in [0, 1)`.
    length : float
        :math:`R` for a linear muscle, :math:`L_s` for a sheet muscle.
    n_wrinkles : int
        Number of wrinkles :math:`n_w \ge 1`.

    Returns
    -------
    float
        .. math:: u = \frac{(1 - \lambda_w) R}{2 n_w}
    """
    return (1.0 - float(lambda_w)) * float(length) / (2.0 * int(n_wrinkles))


def periodic_coordinate(l, lambda_w: float, length: float, n_wrinkles: int) -> np.ndarray:
    r"""Periodic coordinate :math:`w` of a vertex along the wrinkles (Eq. 7).

    Parameters
    ----------
    l : (...) array_like
        Distance :math:`l_i` from the attachment along the central fibre.
    lambda_w, length, n_wrinkles
        As in :func:`half_period`.

    Returns
    -------
    (...) ndarray
        .. math::

            w = l - \lambda_w R - \operatorname{int}\!\left(
                \frac{l - \lambda_w R}{2u}\right) 2u
              = (l - \lambda_w R) \bmod 2u \in [0, 2u),

        where int is the floor, as the paper defines it ("the biggest integer smaller than
        it"), so ``w`` maps ``l`` periodically onto one period with frequency :math:`n_w`.
    """
    u = half_period(lambda_w, length, n_wrinkles)
    return np.mod(np.asarray(l, dtype=float) - lambda_w * length, 2.0 * u)


def anisotropy(eps) -> np.ndarray:
    r"""Anisotropic modulation :math:`A(\varepsilon)` of the wrinkle amplitude (Eq. 11).

    Parameters
    ----------
    eps : (...) array_like
        Compression rate :math:`\varepsilon` (Eq. 10).

    Returns
    -------
    (...) ndarray
        .. math::

            A(\varepsilon) = \begin{cases}
                \cos\!\left(\frac{\pi}{2}(1 - \varepsilon)\right) & 0 \le \varepsilon \le 1 \\
                0 & \varepsilon < 0
            \end{cases}

        :math:`\varepsilon > 1` (an edge shorter than nothing cannot happen, but rounding can
        push past 1) is clamped to 1. ``nan`` stays ``nan``.
    """
    e = np.clip(np.asarray(eps, dtype=float), 0.0, 1.0)
    return np.sin(0.5 * np.pi * e)  # cos(pi/2 (1 - e)) == sin(pi/2 e); 0 at e == 0


def attenuation(x, start: float, end: float) -> np.ndarray:
    r"""Attenuation profile :math:`At` (Eq. 12 for a linear muscle, Eq. 15 for a sheet).

    Parameters
    ----------
    x : (...) array_like
        :math:`\varphi_i` in degrees (linear muscle) or :math:`h_i` (sheet muscle).
    start : float
        :math:`\varphi^c` or :math:`h^c`, where the amplitude starts to decrease.
    end : float
        :math:`\phi` or :math:`W_s / 2`, where it reaches 0; ``end >= start``.

    Returns
    -------
    (...) ndarray
        .. math::

            At(x) = \begin{cases}
                1 & x \le x^c \\
                -\frac{1}{2}\left(1 + s^2\right) s + 1 & x^c < x \le x_{end} \\
                0 & x > x_{end}
            \end{cases}, \qquad s = \frac{x - x^c}{x_{end} - x^c}.

        The cubic is 1 at the start, 0 at the end and strictly decreasing in between. With
        ``start == end`` it is a step. ``nan`` stays ``nan``.
    """
    x = np.asarray(x, dtype=float)
    span = float(end) - float(start)
    if span <= 0.0:
        out = np.where(x <= start, 1.0, 0.0)
        return np.where(np.isnan(x), np.nan, out)
    s = np.clip((x - start) / span, 0.0, 1.0)
    return 1.0 - 0.5 * (1.0 + s * s) * s


def edge_shrinkage(rest_points, points, edges) -> np.ndarray:
    r"""Relative shortening :math:`\tau_{ij}` of each edge (Eq. 9).

    Parameters
    ----------
    rest_points : (n, 3) array_like
        Rest positions.
    points : (n, 3) array_like
        Deformed positions.
    edges : (m, 2) array_like of int
        Vertex pairs.

    Returns
    -------
    (m,) ndarray
        .. math:: \tau_{ij} = \frac{L_{ij} - \|x_i - x_j\|}{L_{ij}}

        0 at rest, positive when the edge shrinks. An edge of zero rest length gives ``nan``.
    """
    rest_points = np.asarray(rest_points, dtype=float)
    points = np.asarray(points, dtype=float)
    edges = np.asarray(edges, dtype=np.intp)
    rest = np.linalg.norm(rest_points[edges[:, 1]] - rest_points[edges[:, 0]], axis=1)
    now = np.linalg.norm(points[edges[:, 1]] - points[edges[:, 0]], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(rest > 0.0, (rest - now) / rest, np.nan)


def _row_positions(n: int, rows) -> tuple[np.ndarray, np.ndarray]:
    """``rows`` (default all ``n``) and ``(n,)``: each vertex's row in them, -1 if none."""
    rows = np.arange(n) if rows is None else np.asarray(rows, dtype=np.intp)
    position = np.full(n, -1, dtype=np.intp)
    position[rows] = np.arange(len(rows))
    return rows, position


def _unit_directions(directions: np.ndarray) -> np.ndarray:
    """``(n, 3)``: ``directions`` ``(n, 3)`` made unit, zero where zero or not finite."""
    dnorm = vector_lengths(directions)
    ok = np.isfinite(dnorm) & (dnorm > 0)
    unit_dir = np.zeros_like(directions)
    unit_dir[ok] = directions[ok] / dnorm[ok, None]
    return unit_dir


def _edge_alignments(edges: np.ndarray, position: np.ndarray, unit_edge: np.ndarray,
                     unit_dir: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""The unnormalized entries of :func:`compression_operator`: for each end of each
    edge ``(m, 2)`` whose vertex has a row (``position`` ``(n,)``, -1 where not), its row,
    the edge's column and :math:`|\hat e \cdot \hat d|` at that vertex.
    """
    r_parts: list[np.ndarray] = []
    c_parts: list[np.ndarray] = []
    v_parts: list[np.ndarray] = []
    for end in (0, 1):
        vertex = edges[:, end]
        pos = position[vertex]
        keep = pos >= 0
        weight = np.abs(np.einsum("ij,ij->i", unit_edge[keep], unit_dir[vertex[keep]]))
        r_parts.append(pos[keep])
        c_parts.append(np.flatnonzero(keep))
        v_parts.append(weight)
    return np.concatenate(r_parts), np.concatenate(c_parts), np.concatenate(v_parts)


def compression_operator(rest_points, edges, directions, rows=None) -> sp.csr_matrix:
    r"""Sparse operator :math:`E` with :math:`\varepsilon = E\,\tau` (Eq. 10).

    Parameters
    ----------
    rest_points : (n, 3) array_like
        Rest positions; the weights come from the rest mesh and stay constant per frame.
    edges : (m, 2) array_like of int
        Unique undirected edges.
    directions : (n, 3) array_like
        Muscle contraction direction at each vertex (need not be unit). Rows that are zero
        or ``nan`` get no weight.
    rows : (k,) array_like of int, optional
        Vertices to build rows for (all ``n`` by default), in this order.

    Returns
    -------
    (k, m) scipy.sparse.csr_matrix
        Row :math:`i` holds :math:`|\cos\theta_{ij}| / \sum_j |\cos\theta_{ij}|` at the
        columns of the edges incident to vertex :math:`i`; an all-zero row where the weight
        sum is 0.

    Notes
    -----
    **Deviation from the paper.** Eq. 10 weights by :math:`\cos\theta_{ij}`. An edge that
    points backwards along the contraction axis is as aligned with it as one pointing
    forwards, and signed weights can make the denominator vanish, so the weights here are
    :math:`|\cos\theta_{ij}|`. Edges of zero rest length get no weight.
    """
    rest_points = np.asarray(rest_points, dtype=float)
    edges = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    directions = np.asarray(directions, dtype=float)
    rows, position = _row_positions(len(rest_points), rows)
    vec = rest_points[edges[:, 1]] - rest_points[edges[:, 0]]
    length = vector_lengths(vec)  # np.linalg.norm's, to the bit, faster
    unit_edge = np.divide(vec, length[:, None], out=np.zeros_like(vec), where=length[:, None] > 0)
    r_idx, c_idx, vals = _edge_alignments(edges, position, unit_edge, _unit_directions(directions))
    total = np.bincount(r_idx, weights=vals, minlength=len(rows))
    with np.errstate(divide="ignore", invalid="ignore"):
        vals = np.where(total[r_idx] > 0, vals / total[r_idx], 0.0)
    op = sp.csr_matrix((vals, (r_idx, c_idx)), shape=(len(rows), len(edges)))
    op.eliminate_zeros()
    return op


def compression(rest_points, points, edges, directions) -> np.ndarray:
    r"""Compression rate :math:`\varepsilon_i` at every vertex (Eq. 10).

    Parameters
    ----------
    rest_points : (n, 3) array_like
        Rest positions.
    points : (n, 3) array_like
        Deformed positions.
    edges : (m, 2) array_like of int
        Unique undirected edges of the mesh.
    directions : (n, 3) array_like
        Contraction direction at each vertex (:math:`x_i m_A` for a linear muscle, the
        central fibre for a sheet muscle).

    Returns
    -------
    (n,) ndarray
        .. math::

            \varepsilon_i = \frac{\sum_{j \in \Omega_i} \tau_{ij} |\cos\theta_{ij}|}
                                 {\sum_{j \in \Omega_i} |\cos\theta_{ij}|}

        with :math:`\tau_{ij}` from Eq. 9 and :math:`\theta_{ij}` the angle between the rest
        edge :math:`x_i x_j` and the contraction direction at :math:`x_i`; 0 where the weight
        sum is 0. See :func:`compression_operator` for the :math:`|\cos|` deviation.
    """
    op = compression_operator(rest_points, edges, directions)
    tau = np.nan_to_num(edge_shrinkage(rest_points, points, edges), nan=0.0)
    return op @ tau


def gradient_compression_operator(rest_points, triangles, directions, rows=None):
    r"""What :func:`gradient_compression` needs from the rest mesh, once.

    Parameters
    ----------
    rest_points : (n, 3) array_like
        Rest positions.
    triangles : (m, 3) array_like of int
        The mesh's triangles.
    directions : (n, 3) array_like
        Contraction direction at each vertex (need not be unit); rows that are zero or
        ``nan`` (outside a muscle's AOI) do not count.
    rows : (k,) array_like of int, optional
        Vertices to build rows for (all ``n`` by default), in this order.

    Returns
    -------
    tri_ids : (t,) int
        The triangles incident to ``rows``, ascending.
    coefficients : (t, 2) float
        :math:`(c_0, c_1)` with :math:`F_t d_t = c_0 (x_b - x_a) + c_1 (x_c - x_a)` for the
        corners :math:`(a, b, c)` of each triangle: the rest edges' least-squares
        (pseudo-inverse) coordinates of :math:`d_t`, the normalized sum of the corners' unit
        directions projected into the rest triangle's plane. 0 where :math:`d_t` or the
        triangle is degenerate.
    operator : (k, t) scipy.sparse.csr_matrix
        Row :math:`i` holds the rest areas of the triangles incident to vertex :math:`i`
        over their sum (degenerate ones excluded): the area-weighted mean; an all-zero row
        where there is none.
    """
    rest_points = np.asarray(rest_points, dtype=float)
    triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    directions = np.asarray(directions, dtype=float)
    rows, position = _row_positions(len(rest_points), rows)
    tri_ids = np.flatnonzero((position[triangles] >= 0).any(axis=1))
    tri = triangles[tri_ids]

    dnorm = vector_lengths(directions)
    ok = np.isfinite(dnorm) & (dnorm > 0)
    unit_dir = np.zeros_like(directions)
    unit_dir[ok] = directions[ok] / dnorm[ok, None]
    coefficients, weight = stretch_coefficients(
        rest_points[tri[:, 0]], rest_points[tri[:, 1]], rest_points[tri[:, 2]],
        unit_dir[tri].sum(axis=1))
    pos = position[tri]
    keep = pos >= 0
    r_idx = pos[keep]
    c_idx = np.broadcast_to(np.arange(len(tri))[:, None], pos.shape)[keep]
    vals = weight[c_idx]
    total = np.bincount(r_idx, weights=vals, minlength=len(rows))
    with np.errstate(divide="ignore", invalid="ignore"):
        vals = np.where(total[r_idx] > 0, vals / total[r_idx], 0.0)
    op = sp.csr_matrix((vals, (r_idx, c_idx)), shape=(len(rows), len(tri)))
    op.eliminate_zeros()
    return tri_ids, coefficients, op



def stretch_coefficients(a, b, c, direction):
    r"""The rest-triangle data of :math:`F_t d_t` for triangles with corners ``a``, ``b``,
    ``c`` ``(t, 3)`` and a summed contraction direction ``direction`` ``(t, 3)``.

    Returns
    -------
    coefficients : (t, 2) float
        :math:`(c_0, c_1)` with :math:`F_t d_t = c_0 (x_b - x_a) + c_1 (x_c - x_a)`: the
        rest edges' least-squares coordinates of :math:`d_t`, ``direction`` projected into
        the rest triangle's plane and made unit; 0 where it or the triangle is degenerate.
    area : (t,) float
        The rest areas, 0 where the coefficients are.
    """
    e1, e2 = b - a, c - a
    normal = np.cross(e1, e2)
    double_area = np.linalg.norm(normal, axis=1)
    flat = double_area > 0
    normal[flat] /= double_area[flat, None]
    d = direction - np.einsum("ij,ij->i", direction, normal)[:, None] * normal
    dlen = np.linalg.norm(d, axis=1)
    valid = flat & (dlen > 1e-9)
    d[valid] /= dlen[valid, None]
    g11 = np.einsum("ij,ij->i", e1, e1)
    g12 = np.einsum("ij,ij->i", e1, e2)
    g22 = np.einsum("ij,ij->i", e2, e2)
    r1 = np.einsum("ij,ij->i", e1, d)
    r2 = np.einsum("ij,ij->i", e2, d)
    det = np.where(valid, g11 * g22 - g12 * g12, 1.0)
    coefficients = np.where(valid[:, None],
                            np.c_[g22 * r1 - g12 * r2, g11 * r2 - g12 * r1] / det[:, None], 0.0)
    return coefficients, np.where(valid, 0.5 * double_area, 0.0)

def triangle_stretch(points, triangles, coefficients) -> np.ndarray:
    r"""``(t,)``: :math:`|F_t d_t|`, the stretch of each triangle along its contraction
    direction, from deformed ``points`` ``(n, 3)``, ``triangles`` ``(t, 3)`` and the
    ``coefficients`` ``(t, 2)`` of :func:`gradient_compression_operator`.
    """
    points = np.asarray(points, dtype=float)
    tri = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    c = np.asarray(coefficients, dtype=float)
    a = points[tri[:, 0]]
    g = c[:, :1] * (points[tri[:, 1]] - a) + c[:, 1:] * (points[tri[:, 2]] - a)
    return np.linalg.norm(g, axis=1)


def gradient_compression(rest_points, points, triangles, directions) -> np.ndarray:
    r"""Compression rate :math:`\varepsilon_i` from the deformation gradient (not the
    paper's: the ``compression="gradient"`` option's alternative to Eq. 10).

    Parameters
    ----------
    rest_points : (n, 3) array_like
        Rest positions.
    points : (n, 3) array_like
        Deformed positions.
    triangles : (m, 3) array_like of int
        The mesh's triangles.
    directions : (n, 3) array_like
        Contraction direction at each vertex; zero or ``nan`` rows do not count.

    Returns
    -------
    (n,) ndarray
        For each triangle :math:`t`, with :math:`F_t` its deformation gradient (the linear
        map from its rest edges to its deformed edges) and :math:`d_t` the unit contraction
        direction in its rest plane,

        .. math::

            \varepsilon_t = 1 - |F_t d_t|, \qquad
            \varepsilon_i = \frac{\sum_{t \ni i} a_t \varepsilon_t}{\sum_{t \ni i} a_t},

        the area-weighted mean over the triangles around vertex :math:`i` (rest areas
        :math:`a_t`); 0 where no triangle counts.

    Notes
    -----
    Exact for a uniform strain: if the skin is compressed by :math:`e` along the contraction
    direction (any affine map with :math:`|F d| = 1 - e`) every triangle gives :math:`e`,
    whatever the mesh. Eq. 10 (:func:`compression`) averages the edges' shortening
    :math:`\tau_{ij}`, which for that strain is :math:`e \cos^2\theta_{ij}` to first order,
    with :math:`|\cos\theta_{ij}|` weights: about two thirds of :math:`e` for edges spread
    evenly in angle, and a value that depends on the edge directions around each vertex on
    an irregular mesh. A rigid motion gives :math:`|F_t d_t| = 1`, :math:`\varepsilon = 0`.
    """
    triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    tri_ids, coefficients, op = gradient_compression_operator(rest_points, triangles,
                                                              directions)
    return op @ (1.0 - triangle_stretch(points, triangles[tri_ids], coefficients))
