"""The physical skin's equilibrium across resolutions: the 20k face against the 60k face.

The measure (issue 27, "the equilibrium on the 20k and 60k faces agrees within 5 %"): each
vertex of the coarse face is located on the fine face's rest skin (its closest point, as a
triangle and barycentric weights, :func:`~wrinkle_vis.core.mesh.surface_coordinates`), the
fine face's displacement is interpolated there, and

.. math::

    e_i = |u^{c}_i - u^{f}(p_i)| / \\max_j |u^{c}_j|

is taken over the coarse vertices that move by at least ``--floor`` (default 10 %) of the
largest displacement (below that the difference is relative to nothing). Two schemes
interpolate :math:`u^f`: linear (:func:`~wrinkle_vis.core.mesh.barycentric_points`) and a
local quadratic fit (:func:`~wrinkle_vis.core.mesh.quadratic_points`). Printed for each:
the RMS, 99th percentile and maximum of :math:`e`, and where the worst vertex is. Before
them, each scheme on the muscles' closed-form pull (:meth:`Muscle.unit_displacement`, a
function of the rest position, so exact at the coarse vertex): the comparison's own
interpolation error. The geometric skin is measured the same way beside the physical one.
For the physical skin, also the *spring response* (equilibrium minus the muscles' pull,
:meth:`FaceModel.muscle_displacement`): the fine equilibrium rebuilt at the coarse vertex
as the pull there plus the linearly interpolated response. The furrows' positions: the
forehead's furrows (surprise) on the six lines of ``tests/test_realism.py``, the largest
distance from a fine furrow deeper than 0.3 mm to the nearest coarse one, in periods of
the frontalis' wrinkles.

Run:  .venv/bin/python benchmarks/bench_physical_convergence.py [--triangles 20000 60000]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import wrinkle_vis as wv
from wrinkle_vis.core.mesh import barycentric_points, quadratic_points, surface_coordinates

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


SCHEMES = {"linear": barycentric_points, "quadratic": quadratic_points}


def displacement_error(coarse, fine, where, u_coarse, u_fine, keep, top: float,
                       scheme) -> dict:
    """The per-vertex measure of the module docstring over ``keep``, ``u_fine``
    interpolated at ``where`` (``surface_coordinates``' triangles and weights) by
    ``scheme``."""
    e = np.linalg.norm(u_coarse - scheme(fine.skin, *where, u_fine), axis=1)[keep] / top
    worst = np.flatnonzero(keep)[np.argmax(e)]
    return {"rms": float(np.sqrt(np.mean(e**2))), "p99": float(np.percentile(e, 99)),
            "max": float(e.max()), "worst_at": coarse.skin.points[worst],
            "worst_u": float(np.linalg.norm(u_coarse[worst]))}


def closed_form_pull(face, acts) -> np.ndarray:
    """``(n, 3)``: the muscles' closed-form pull (:meth:`Muscle.unit_displacement`) at
    the face's rest vertices."""
    return sum(a * face.muscle(n).unit_displacement(face.skin.points)
               for n, a in acts.items() if a > 0.0)


def report(label: str, r: dict) -> str:
    """One line of :func:`displacement_error`'s figures."""
    return (f"{label}: RMS {r['rms']:.2%}, p99 {r['p99']:.2%}, max {r['max']:.2%} at "
            f"{np.round(r['worst_at'], 1)} (|u| {r['worst_u']:.3f})")


def furrow_gap(coarse_state, fine_state, period: float) -> float:
    """The largest distance from a fine furrow (> 0.3 mm deep) to the nearest coarse one on
    the same forehead line, over ``period``."""
    from test_realism import forehead_rows

    gap = 0.0
    for a, b in zip(forehead_rows(fine_state), forehead_rows(coarse_state), strict=True):
        for p in a["furrow_points"][np.asarray(a["depths"]) > 0.3]:
            if len(b["furrow_points"]) == 0:
                return float("inf")
            gap = max(gap, float(np.linalg.norm(b["furrow_points"] - p, axis=1).min()))
    return gap / period


def measure(coarse, fine, where, name: str, skin: str, floor: float, period: float) -> None:
    """Print the comparison of expression ``name`` on ``skin`` (module docstring)."""
    sc, sf = (f.evaluate(name, skin=skin) for f in (coarse, fine))
    uc = sc.deformed_points - coarse.skin.points
    uf = sf.deformed_points - fine.skin.points
    top = float(np.linalg.norm(uc, axis=1).max())
    keep = np.linalg.norm(uc, axis=1) >= floor * top
    print(f"{name} {skin}: |u| max {top:.3f} mm; {keep.sum()} vertices >= {floor:.0%} of it")
    if skin == "physical":  # the comparison's own interpolation error
        pc, pf = (closed_form_pull(f, sc.activations) for f in (coarse, fine))
        for label, scheme in SCHEMES.items():
            r = displacement_error(coarse, fine, where, pc, pf, keep, top, scheme)
            print("  " + report(f"closed-form pull, {label:9s}", r))
    for label, scheme in SCHEMES.items():
        r = displacement_error(coarse, fine, where, uc, uf, keep, top, scheme)
        print("  " + report(f"whole displacement, {label:9s}", r))
    if skin == "physical":  # what the springs add to the muscles' pull
        dc = coarse.muscle_displacement(sc.activations)
        df = fine.muscle_displacement(sf.activations)
        r = displacement_error(coarse, fine, where, uc - dc, uf - df, keep, top,
                               barycentric_points)
        print(f"  spring response: largest {np.linalg.norm(uc - dc, axis=1).max():.3f} mm; "
              + report("pull + response rebuilt", r))
    if name == "surprise":
        print(f"  furrow gap {furrow_gap(sc, sf, period):.3f} period")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, nargs=2, default=[20000, 60000])
    ap.add_argument("--floor", type=float, default=0.1)
    ap.add_argument("--expressions", nargs="+", default=["surprise", "frown"])
    args = ap.parse_args()
    print(f"load average {open('/proc/loadavg').read().split()[0]}")
    coarse, fine = (wv.datasets.load_face(n_triangles=n) for n in args.triangles)
    where = surface_coordinates(fine.skin, coarse.skin.points)
    period = 2.0 * coarse.muscle("frontalis_inner_L").u
    for name in args.expressions:
        for skin in ("geometric", "physical"):
            t0 = time.perf_counter()
            measure(coarse, fine, where, name, skin, args.floor, period)
            print(f"  [{time.perf_counter() - t0:.1f} s]", flush=True)


if __name__ == "__main__":
    main()
