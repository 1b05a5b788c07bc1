"""Adaptive refinement against VTK's uniform subdivision (linear and butterfly), side by side.

Run:  .venv/bin/python benchmarks/bench_refine_fidelity.py

Fidelity is the largest distance, along the central fibre of frontalis_major_L on surprise,
from the reference wrinkled surface to each candidate's wrinkled surface. The reference is
the model evaluated on the skin refined uniformly four times with the refinement's own
smooth (Phong) midpoints, 1.15 M triangles: the surface the adaptive refinement converges
to. Candidates: the adaptive refinement of ``evaluate(refine=True)`` at the paper's size, and
the skin subdivided uniformly n times by VTK and then evaluated the same way, with linear
midpoints (``PolyData.subdivide(n, "linear")``, which keeps the coarse facets) and with the
interpolating butterfly scheme (``"butterfly"``, smooth).
Fidelity and time are taken on dynamic frames: the surprise ramp from 0 to 1 in 30 steps,
every frame a new intensity (so the adaptive refinement splits another set of triangles
nearly every frame); fidelity is the worst over intensities 0.5, 0.75 and 1. Time: building
the model for that mesh plus its first frame (``setup+frame``; for VTK the subdivision too),
and the median frame of the ramp (``frame``).

The last lines compare the adaptive refinement with the uniform subdivision that reaches the
same fidelity (the first uniform candidate at least as close to the reference, within 5 %):
the target is at most a fifth of the triangles and at most half the time.
"""

import argparse
import statistics
import time

import numpy as np
from _timing import median_seconds

import wrinkle_vis as wv
from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.core.refine import refine_triangles
from wrinkle_vis.plotting import to_surface_polydata

MUSCLE = "frontalis_major_L"
LEVELS = (0.5, 0.75, 1.0)  # intensities the fidelity is taken at


def ramp_ms(frame_at, steps=30, rounds=3):
    """Median milliseconds of a frame of the ramp 0..1 in ``steps`` steps (median of the
    rounds' medians)."""
    medians = []
    for _ in range(rounds):
        times = []
        for i in range(steps + 1):
            t0 = time.perf_counter()
            frame_at(i / steps)
            times.append(time.perf_counter() - t0)
        medians.append(statistics.median(times))
    return 1e3 * statistics.median(medians)


def fibre_band(state, width=0.5):
    """Final points of ``state`` within ``width`` of the muscle's central fibre, in its region."""
    m = state.face.muscle(MUSCLE)
    _, s, _ = m.frame
    v = state.rest_points - m.attachment_center
    near = (np.abs(v @ s) < width) & np.isfinite(state.fields[MUSCLE]["H"])
    return state.points[near], (v @ m.frame[0])[near], state.fields[MUSCLE]["H"][near]


def crests(l, h, m):
    h = h[np.argsort(l)]
    above = h > 0.5 * (m.d + (m.d - m.k0 * 2**m.alpha))
    return int(np.count_nonzero(above[1:] & ~above[:-1]) + int(above[0]))


def fidelity(reference_points, state):
    surface = wv.TriangleSurface(state.points, state.triangles)
    return float(np.linalg.norm(closest_points(surface, reference_points) - reference_points,
                                axis=1).max())


def smooth_uniform(skin, levels):
    """``skin`` refined uniformly ``levels`` times with the adaptive refinement's midpoints."""
    normals = None
    for _ in range(levels):
        ref = refine_triangles(skin, np.ones(skin.n_triangles, bool), normals)
        skin, normals = ref.surface, ref.normals
    return skin


def timed(fn, n=5):
    """Median milliseconds of ``n`` calls, and the last call's result."""
    out = fn()
    return 1e3 * median_seconds(fn, n, 1), out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--angle", type=float, default=3.0, help="refine_angle_deg")
    parser.add_argument("--levels", type=int, default=3, help="refine_levels")
    args = parser.parse_args()
    options = {"refine": True, "refine_angle_deg": args.angle, "refine_levels": args.levels}
    base = wv.datasets.load_face().with_skin_model("geometric")
    muscle = base.muscle(MUSCLE)
    ref_face = wv.FaceModel(smooth_uniform(base.skin, 4), base.skull, base.muscles,
                            base.expressions, skin_model="geometric")
    refs = {t: fibre_band(ref_face.evaluate("surprise", t), width=0.3)[0] for t in LEVELS}
    ref_points, ref_l, ref_h = fibre_band(ref_face.evaluate("surprise"), width=0.3)
    print(f"reference: {ref_face.skin.n_triangles} triangles, {len(ref_points)} points along "
          f"the fibre, {crests(ref_l, ref_h, muscle)} crests (n_w = {muscle.n_wrinkles})")
    rows = []

    def adaptive_setup():
        face = wv.FaceModel(base.skin, base.skull, base.muscles, base.expressions,
                            skin_model="geometric")
        return face.evaluate("surprise", **options)

    setup_ms, _ = timed(adaptive_setup)
    rows.append(("adaptive", lambda t: base.evaluate("surprise", t, **options), setup_ms,
                 ramp_ms(lambda t: base.evaluate("surprise", t, **options))))
    for scheme, n in [(s, n) for s in ("linear", "butterfly") for n in (1, 2, 3)]:
        poly = to_surface_polydata(base.skin).subdivide(n, scheme)
        skin = wv.TriangleSurface(poly.points, poly.faces.reshape(-1, 4)[:, 1:])

        def uniform_setup(skin=skin):
            face = wv.FaceModel(skin, base.skull, base.muscles, base.expressions,
                                skin_model="geometric")
            return face.evaluate("surprise")

        subdiv_ms, _ = timed(lambda n=n, scheme=scheme: to_surface_polydata(base.skin).subdivide(
            n, scheme))
        setup_ms, state = timed(uniform_setup, n=3)
        face = state.face
        rows.append((f"VTK {scheme} x{n}", lambda t, face=face: face.evaluate("surprise", t),
                     subdiv_ms + setup_ms, ramp_ms(lambda t, face=face: face.evaluate(
                         "surprise", t))))

    print(f"{'':16}{'triangles':>11}{'fidelity mm':>13}{'crests':>8}{'setup+frame ms':>16}"
          f"{'frame ms':>10}")
    table = []
    for name, frame_at, setup, frame in rows:
        states = {t: frame_at(t) for t in LEVELS}
        state = states[1.0]
        _, l, h = fibre_band(state, width=1.0)
        fid = max(fidelity(refs[t], states[t]) for t in LEVELS)
        table.append((name, len(state.triangles), fid, setup, frame))
        print(f"{name:16}{len(state.triangles):>11}{fid:>13.3f}"
              f"{crests(l, h, muscle):>8}{setup:>16.1f}{frame:>10.2f}")
    ours = table[0]
    peer = next((row for row in table[1:] if row[2] <= ours[2] * 1.05), None)
    if peer is None:
        print("no uniform subdivision here is as faithful as the adaptive refinement")
        return
    print(f"same fidelity as {peer[0]}: triangles x{ours[1] / peer[1]:.3f} (target <= 0.2), "
          f"setup+frame time x{ours[3] / peer[3]:.2f} (target <= 0.5), "
          f"dynamic frame x{ours[4] / peer[4]:.2f} (target <= 0.5)")


if __name__ == "__main__":
    main()
