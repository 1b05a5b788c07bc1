"""The physical skin's equilibrium across resolutions: the 20k face against the 60k face.

The measure (issue 27, "the equilibrium on the 20k and 60k faces agrees within 5 %"): each
vertex of the coarse face is located on the fine face's rest skin (its closest point, as a
triangle and barycentric weights, :func:`~wrinkle_vis.core.mesh.surface_coordinates`), the
fine face's displacement is interpolated there, and

.. math::

    e_i = |u^{c}_i - u^{f}(p_i)| / \\max_j |u^{c}_j|

is taken over the coarse vertices that move by at least ``--floor`` (default 10 %) of the
largest displacement (below that the difference is relative to nothing). Printed: the RMS,
99th percentile and maximum of :math:`e`, and where the worst vertex is. The geometric
skin is measured the same way beside it, and so is the muscles' closed-form pull
(:meth:`Muscle.unit_displacement`) sampled at the fine vertices: what linear interpolation
alone leaves where the pull turns fast. For the physical skin, also the *spring response*
(equilibrium minus the muscles' pull, :meth:`FaceModel.muscle_displacement`) compared the
same way: the fine equilibrium rebuilt at the coarse vertex as the pull there plus the
interpolated response, which is what ``tests/test_physical.py`` holds to 5 %. The furrows'
positions: the forehead's furrows (surprise) on the six lines of ``tests/test_realism.py``,
the largest distance from a fine furrow deeper than 0.3 mm to the nearest coarse one, in
periods of the frontalis' wrinkles.

Run:  .venv/bin/python benchmarks/bench_physical_convergence.py [--triangles 20000 60000]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import wrinkle_vis as wv
from wrinkle_vis.core.mesh import barycentric_points, surface_coordinates

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def displacement_error(coarse, fine, u_coarse, u_fine, floor: float) -> dict:
    """The per-vertex measure of the module docstring."""
    tri, bary = surface_coordinates(fine.skin, coarse.skin.points)
    u_at = barycentric_points(fine.skin, tri, bary, u_fine)
    size = np.linalg.norm(u_coarse, axis=1)
    top = size.max()
    keep = size >= floor * top
    e = np.linalg.norm(u_coarse - u_at, axis=1)[keep] / top
    worst = np.flatnonzero(keep)[np.argmax(e)]
    return {"rms": float(np.sqrt(np.mean(e**2))), "p99": float(np.percentile(e, 99)),
            "max": float(e.max()), "worst_at": coarse.skin.points[worst],
            "worst_u": float(size[worst]), "top": float(top), "kept": int(keep.sum())}


def masked_max(coarse, fine, a, b, keep, top) -> float:
    """The largest :math:`|a_i - b(p_i)|` over ``keep``, over ``top``."""
    tri, bary = surface_coordinates(fine.skin, coarse.skin.points)
    at = barycentric_points(fine.skin, tri, bary, b)
    return float(np.linalg.norm(a - at, axis=1)[keep].max() / top)


def pull_interpolation(coarse, fine, acts, floor: float) -> str:
    """How far linear interpolation on the fine skin is from the muscles' closed-form pull
    (:meth:`Muscle.unit_displacement`, before it is made tangential) at the coarse vertices:
    the part of the comparison no skin model can remove."""
    def pull(points):
        return sum(a * m.unit_displacement(points) for m, a in
                   ((coarse.muscle(n), a) for n, a in acts.items()) if a > 0.0)

    exact = pull(coarse.skin.points)
    tri, bary = surface_coordinates(fine.skin, coarse.skin.points)
    at = barycentric_points(fine.skin, tri, bary, pull(fine.skin.points))
    size = np.linalg.norm(exact, axis=1)
    keep = size >= floor * size.max()
    e = np.linalg.norm(exact - at, axis=1)[keep] / size.max()
    worst = np.flatnonzero(keep)[np.argmax(e)]
    return (f"closed-form pull interpolated on the fine skin: RMS {np.sqrt(np.mean(e**2)):.2%}"
            f", max {e.max():.2%} at {np.round(coarse.skin.points[worst], 1)}")


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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, nargs=2, default=[20000, 60000])
    ap.add_argument("--floor", type=float, default=0.1)
    ap.add_argument("--expressions", nargs="+", default=["surprise", "frown"])
    args = ap.parse_args()
    print(f"load average {open('/proc/loadavg').read().split()[0]}")
    coarse, fine = (wv.datasets.load_face(n_triangles=n) for n in args.triangles)
    period = 2.0 * coarse.muscle("frontalis_inner_L").u
    for name in args.expressions:
        for skin in ("geometric", "physical"):
            t0 = time.perf_counter()
            sc, sf = (f.evaluate(name, skin=skin) for f in (coarse, fine))
            uc = sc.deformed_points - coarse.skin.points
            uf = sf.deformed_points - fine.skin.points
            r = displacement_error(coarse, fine, uc, uf, args.floor)
            if skin == "physical":  # what the springs add to the muscles' pull
                dc = coarse.muscle_displacement(sc.activations)
                df = fine.muscle_displacement(sf.activations)
                added = displacement_error(coarse, fine, uc - dc, uf - df, 0.0)
                added_norm = np.linalg.norm(uc - dc, axis=1).max()
                keep = np.linalg.norm(uc, axis=1) >= args.floor * r["top"]
                worst = masked_max(coarse, fine, uc - dc, uf - df, keep, r["top"])
                print(f"{name:9s} added by the springs: largest {added_norm:.3f} mm; "
                      f"difference over the vertices >= {args.floor:.0%} of |u| max, in "
                      f"% of |u| max: max {worst:.2%}"
                      f" (everywhere: {added['max'] * added['top'] / r['top']:.2%})")
            else:  # the pull's own interpolation error: the muscles' closed-form
                # displacement sampled at the fine vertices, interpolated at the coarse ones
                print(f"{name:9s} {pull_interpolation(coarse, fine, sc.activations, args.floor)}")
            line = (f"{name:9s} {skin:9s}: |u| max {r['top']:.3f} mm; over {r['kept']} "
                    f"vertices >= {args.floor:.0%} of it: RMS {r['rms']:.2%}, p99 "
                    f"{r['p99']:.2%}, max {r['max']:.2%} at {np.round(r['worst_at'], 1)} "
                    f"(|u| {r['worst_u']:.3f})")
            if name == "surprise":
                line += f"; furrow gap {furrow_gap(sc, sf, period):.3f} period"
            print(line + f"  [{time.perf_counter() - t0:.1f} s]", flush=True)


if __name__ == "__main__":
    main()
