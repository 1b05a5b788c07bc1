"""A muscle drag's model work on the physical skin, beside the geometric skin and a baseline.

Run:  .venv/bin/python benchmarks/bench_physical_drag.py [--triangles 4500 20000]
      [--runs 5] [--steps 24] [--baseline /path/to/another/checkout]

One drag step is what the app's model does for each mouse move while a muscle's handle is
held: the moved muscle put in the face (``face.with_muscle(with_point(...))``, each step's
face derived from the previous step's, as the app's session does) and the face evaluated
for surprise (``face.evaluate``, fields and fold guard included, no drawing). The
insertion line's first point of ``frontalis_major_L`` goes round a circle of ``--radius``
mm, ``--steps`` steps a run (continuous positions, not snapped to vertices).

Side by side in one run, for each face size: the geometric skin and the physical skin of
this checkout, and, with ``--baseline``, the physical and geometric skins of the checkout at
that path (imported through ``PYTHONPATH`` in a child process, the same interpreter). Each
figure is the median over ``--runs`` runs of the median step: CPU time of the process
(steadier on a shared machine) and wall time. The load average is printed with them.
Before the runs, one unmeasured drag warms every variant up (the face's first physical
frame, its factorization and muscle data).
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np

MUSCLE = "frontalis_major_L"


def drag_step_times(face, skin: str, steps: int, radius: float) -> tuple[list, list, object]:
    """CPU and wall seconds of each of ``steps`` drag steps of ``face`` on ``skin``, and the
    last step's face.
    """
    from wrinkle_vis.core.editing import with_point

    start = np.array(face.muscle(MUSCLE).insertion_line[0], dtype=float)
    # as the app drags: warm starts where this checkout has them (an older one always does)
    warm = {"warm_start": True} if "warm_start" in inspect.signature(face.evaluate).parameters \
        else {}
    cpu, wall = [], []
    for k in range(steps):
        t = 2.0 * np.pi * (k + 1) / steps
        point = start + radius * np.array([np.sin(t), 1.0 - np.cos(t), 0.0])
        c0, w0 = time.process_time(), time.perf_counter()
        face = face.with_muscle(with_point(face.muscle(MUSCLE), "insertion_line", 0, point))
        face.evaluate("surprise", skin=skin, **warm)
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return cpu, wall, face


def measure(triangles: int, skins: list[str], runs: int, steps: int, radius: float) -> dict:
    """``{skin: {"cpu_ms", "wall_ms", "runs_cpu_ms"}}`` for a face of ``triangles``."""
    import wrinkle_vis as wv

    base = wv.datasets.load_face(triangles)
    faces = {s: base.with_skin_model(s) for s in skins}
    for s in skins:
        faces[s].evaluate("surprise", skin=s)
        drag_step_times(faces[s], s, 4, radius)  # warm-up: first frames, muscle data
    per = {s: ([], []) for s in skins}
    for _ in range(runs):
        for s in skins:  # interleaved, so that a change of load hits every variant
            cpu, wall, _ = drag_step_times(faces[s], s, steps, radius)
            per[s][0].append(statistics.median(cpu))
            per[s][1].append(statistics.median(wall))
    out = {"n_triangles": base.skin.n_triangles, "n_points": base.skin.n_points}
    for s in skins:
        out[s] = {"cpu_ms": 1e3 * statistics.median(per[s][0]),
                  "wall_ms": 1e3 * statistics.median(per[s][1]),
                  "runs_cpu_ms": [round(1e3 * x, 2) for x in per[s][0]]}
    return out


def factorizations(triangles: int, steps: int, radius: float) -> int | None:
    """How many global matrices a drag of ``steps`` steps factorized on this checkout's
    physical skin (None where the skin does not count them).
    """
    import wrinkle_vis as wv

    face = wv.datasets.load_face(triangles).with_skin_model("physical")
    face.evaluate("surprise")
    shared = getattr(face.physical_skin(), "shared", None)
    if shared is None:
        return None
    before = shared.factorizations
    drag_step_times(face, "physical", steps, radius)
    return shared.factorizations - before


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, nargs="+", default=[4500])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--steps", type=int, default=24)
    parser.add_argument("--radius", type=float, default=4.0, help="mm")
    parser.add_argument("--baseline", default=None,
                        help="a checkout of another version, timed in a child process")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:  # the baseline's side: one JSON line
        print(json.dumps({str(n): measure(n, ["geometric", "physical"], args.runs, args.steps,
                                          args.radius) for n in args.triangles}))
        return 0
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores at the start")
    for n in args.triangles:
        ours = measure(n, ["geometric", "physical"], args.runs, args.steps, args.radius)
        theirs = None
        if args.baseline:
            env = dict(os.environ, PYTHONPATH=os.path.abspath(args.baseline))
            done = subprocess.run(
                [sys.executable, os.path.abspath(__file__), "--worker", "--triangles", str(n),
                 "--runs", str(args.runs), "--steps", str(args.steps), "--radius",
                 str(args.radius)], env=env, capture_output=True, text=True, check=True,
                cwd=os.path.abspath(args.baseline))
            theirs = json.loads(done.stdout.strip().splitlines()[-1])[str(n)]
        count = factorizations(n, args.steps, args.radius)
        geo, phys = ours["geometric"], ours["physical"]
        print(f"{ours['n_triangles']} triangles ({ours['n_points']} vertices), a drag step "
              f"(with_muscle + evaluate('surprise')), median of {args.runs} runs x "
              f"{args.steps} steps:")
        print(f"  geometric, this checkout   {geo['cpu_ms']:7.2f} ms CPU {geo['wall_ms']:7.2f} "
              f"ms wall  runs {geo['runs_cpu_ms']}")
        print(f"  physical, this checkout    {phys['cpu_ms']:7.2f} ms CPU {phys['wall_ms']:7.2f} "
              f"ms wall  runs {phys['runs_cpu_ms']}  ({phys['cpu_ms'] / geo['cpu_ms']:.2f} x "
              f"the geometric; {count} factorizations in a {args.steps}-step drag)")
        if theirs is not None:
            for s in ("geometric", "physical"):
                t = theirs[s]
                print(f"  {s + ', baseline':26s} {t['cpu_ms']:7.2f} ms CPU {t['wall_ms']:7.2f} "
                      f"ms wall  runs {t['runs_cpu_ms']}")
            print(f"  physical: baseline / this checkout = "
                  f"{theirs['physical']['cpu_ms'] / phys['cpu_ms']:.1f} x (CPU)")
        print(f"  load average {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
