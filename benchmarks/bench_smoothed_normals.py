"""The first frame of a large face, with the smoothed normals' solve of before (SciPy's
``cg`` per column, Jacobi, rtol 1e-12) and of now (one block CG, two-level cycle, rtol 1e-8),
side by side in one process (issue 33 M12).

Run:  .venv/bin/python benchmarks/bench_smoothed_normals.py [--levels 3] [--rounds 3]

``--levels`` midpoint subdivisions of the 5,100-triangle procedural face (3: 326 k triangles,
4: 1.3 M). Each figure is the median over ``--rounds`` rounds; the first frame is timed on a
fresh ``FaceModel`` each round (its rest frame and operators built anew), its peak memory
traced (tracemalloc: numpy and SciPy arrays) in the first round.
"""

from __future__ import annotations

import argparse
import statistics
import time
import tracemalloc

import numpy as np
import scipy.sparse as sp


def jacobi_cg_normals(surface, normals, radius: float) -> np.ndarray:
    """The solve as it was: three SciPy ``cg`` calls, Jacobi, rtol 1e-12, 2,000 steps."""
    from scipy.sparse.linalg import cg

    from wrinkle_vis.core.mesh import cotangent_laplacian, unit_rows

    n = np.asarray(normals, dtype=float)
    if radius <= 0:
        return n
    stiffness, areas = cotangent_laplacian(surface)
    system = (sp.diags(areas) + 0.5 * radius**2 * stiffness).tocsr()
    jacobi = sp.diags(1.0 / system.diagonal())
    out = np.empty_like(n)
    for c in range(3):
        out[:, c], _ = cg(system, areas * n[:, c], x0=n[:, c], rtol=1e-12, maxiter=2000,
                          M=jacobi)
    return unit_rows(out)


def first_frame(skin, base, solver) -> tuple[float, float, np.ndarray]:
    """Seconds and peak traced MiB of a fresh face's first frame, and its slide normals."""
    import wrinkle_vis as wv
    import wrinkle_vis.core.restgeometry as rest_geometry

    before = rest_geometry.smoothed_normals
    rest_geometry.smoothed_normals = solver
    try:
        face = wv.FaceModel(skin, base.skull, base.muscles, base.expressions,
                            skin_model="geometric")
        acts = {m: 0.7 for m in face.muscle_names}
        tracemalloc.start()
        t0 = time.perf_counter()
        face.evaluate(acts)
        seconds = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        return seconds, peak, face._rest.slide_normals
    finally:
        rest_geometry.smoothed_normals = before


def main() -> None:
    import wrinkle_vis as wv
    from wrinkle_vis.core.mesh import smoothed_normals

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--levels", type=int, default=3)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    base = wv.datasets.load_face(5100)
    skin = wv.subdivide(base.skin, args.levels)
    _ = skin.edges, skin.incidence  # topology is part of loading the mesh
    solvers = {"before (cg, Jacobi)": jacobi_cg_normals, "now (block CG, 2-level)":
               smoothed_normals}
    rows = {name: {"s": [], "peak": None, "normals": None} for name in solvers}
    for _ in range(args.rounds):
        for name, solver in solvers.items():  # interleaved: the same load for both
            s, peak, normals = first_frame(skin, base, solver)
            rows[name]["s"].append(s)
            rows[name]["peak"] = rows[name]["peak"] or peak
            rows[name]["normals"] = normals
    a, b = (rows[n]["normals"] for n in solvers)
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1, 1))).max()
    print(f"{skin.n_triangles:,} triangles, {skin.n_points:,} vertices; "
          f"median of {args.rounds} rounds")
    print(f"{'':>26}{'first frame s':>15}{'peak MiB':>10}")
    for name, row in rows.items():
        print(f"{name:>26}{statistics.median(row['s']):>15.2f}{row['peak']:>10.0f}")
    print(f"largest angle between the two solves' slide normals: {angle:.2e} degrees")


if __name__ == "__main__":
    main()
