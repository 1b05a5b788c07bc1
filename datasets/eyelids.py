r"""Untangling a scan's eyelids: the rest skin smoothed where it passes through itself.

The Lee Perry-Smith head's eyelids cross at rest (the lower lid's margin curls back into the
socket through the lid in front of it: 122 crossing triangle pairs, most of the sheets at
60-100 degrees to each other, some facing the same way), and so does one ear (3 pairs); at the
eyes' corners the skin is folded flat onto itself around a vertex. The fold guard's proof
(``docs/model.md``) needs a rest skin that does not cross itself, and the certificate counts
every new pair two crossing sheets make as they slide along each other under a pull, so the
built-in head's derivation (``scripts/write_lee_perry_smith.py``) untangles them with
:func:`untangle`.

The lips' repair (:mod:`wrinkle_vis.datasets.lips`) pushes each sheet out of the other's
plane, which separates two sheets that face each other and diverges where they do not. A fold
that passes through itself is a place where the surface turns faster than its triangles can
follow; the umbrella (uniform Laplacian) step

.. math::

    x_v \leftarrow x_v + \mu \Big(\frac{1}{|N(v)|} \sum_{w \in N(v)} x_w - x_v\Big)

on the corners of the crossing triangles only (every other vertex stays put) lowers that
turning whatever the sheets' orientation, so repeated steps (each followed by the certificate
on the skin rounded to float32, as the package stores it) unwind the fold. Where the sheets
cross away from the turn (a loop whose branches are flat where they meet), smoothing their
corners moves nothing: when ``patience`` steps in a row leave as many pairs as the fewest
seen, the smoothed region grows by one ring of neighbours (up to the turn). Once nothing
crosses, ``clearance`` more steps on every vertex that ever crossed, and on the corners of the
flat folds asked for (:func:`~wrinkle_vis.datasets.lips.folded_pairs`), open a little room
between the sheets, so that the pulls of an expression and the refined surface (which bulges
beyond the triangles) do not press them through each other again.

The same steps on the corners of flat folds alone (the eyes' and the mouth's corners, where
the skin is folded onto itself around a vertex) open them a little: ``untangle`` on a skin
that does not cross, with those vertices as ``hold``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from wrinkle_vis.core.certificate import intersecting_pairs

__all__ = ["untangle"]


def _adjacency(n: int, tri: np.ndarray) -> sp.csr_matrix:
    """``(n, n)``: 1 where two of the ``n`` vertices share an edge of ``tri`` ``(m, 3)``."""
    e = np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    a = sp.coo_matrix((np.ones(2 * len(e)), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])),
                      shape=(n, n)).tocsr()
    a.data[:] = 1.0
    return a


def untangle(points: np.ndarray, triangles: np.ndarray, region: np.ndarray | None = None,
             step: float = 0.25, clearance: int = 4, hold: np.ndarray | None = None,
             max_steps: int = 200, patience: int = 5, float32: bool = True) -> np.ndarray:
    r"""``(n, 3)``: ``points`` ``(n, 3)`` with the triangles ``(m, 3)`` that cross each other
    (both triangles' corners inside ``region`` ``(n,) bool``, default everywhere) smoothed
    by umbrella steps of size ``step`` (:math:`\mu`, module notes) on their corners (and
    one more ring of neighbours each time ``patience`` steps bring no fewer pairs) until
    none crosses, then ``clearance`` more steps on every vertex that ever crossed and on
    the vertices ``hold`` ``(n,) bool`` (say, flat folds to open).
    ``float32``: every step's skin is rounded to float32 (as the package stores it) and
    checked so.

    Raises ``RuntimeError`` when crossings are left after ``max_steps`` steps.
    """
    tri = np.asarray(triangles, dtype=np.intp)
    pts = np.array(points, dtype=float, copy=True)
    n = len(pts)
    adjacency = _adjacency(n, tri)
    degree = np.maximum(np.asarray(adjacency.sum(axis=1)).ravel(), 1.0)[:, None]
    inside = np.ones(len(tri), bool) if region is None else np.asarray(region, bool)[tri].all(1)
    seen = np.zeros(n, bool) if hold is None else np.asarray(hold, bool).copy()
    extra, rings, fewest, idle = 0, 0, len(tri) ** 2, 0
    for _ in range(max_steps):
        if float32:
            pts = pts.astype(np.float32).astype(float)
        pairs = intersecting_pairs(pts, tri)
        pairs = pairs[inside[pairs].all(axis=1)] if len(pairs) else pairs
        if len(pairs):
            fewest, idle = min(fewest, len(pairs)), 0 if len(pairs) < fewest else idle + 1
            if idle >= patience:
                rings, idle = rings + 1, 0
            move = np.zeros(n, bool)
            move[tri[pairs.ravel()].ravel()] = True
            for _ in range(rings):
                move |= (adjacency @ move.astype(float)) > 0
            seen |= move
        elif extra < clearance and seen.any():
            move, extra = seen, extra + 1
        else:
            return pts
        pts[move] += step * ((adjacency @ pts)[move] / degree[move] - pts[move])
    raise RuntimeError(f"the skin still crosses itself after {max_steps} steps; "
                       "raise max_steps or step")
