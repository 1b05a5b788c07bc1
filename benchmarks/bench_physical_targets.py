"""Issue 27's correctness targets of the physical skin measured on a built-in face.

The tests check them on small faces (``tests/test_physical.py``); this measures the same
quantities on a whole built-in face, the procedural one or the scanned head:

- drift: the largest distance from rest after 1,000 steps of 1/30 s with no activation,
  over the skin's size (target: at most 1e-9);
- a step to surprise at t = 0, time steps 10 ms and 1/30 s: the time at which the sum of
  |W| reaches 90 % of its value at 0.6 s (target 50-300 ms) and its overshoot (target at
  most 10 %);
- a ramp to surprise over 0.4 s, 1 s simulated at 1/30 and 1/60 s: the largest difference
  of the displacements at the common times over the largest displacement (target 2 %);
- the energy of the damped free skin released from the surprise equilibrium: how often it
  rose from one step to the next over 60 steps (target: never).

Run:  .venv/bin/python benchmarks/bench_physical_targets.py [--face lee_perry_smith]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import wrinkle_vis as wv

H = 1.0 / 30.0


def drift(face, steps: int = 1000) -> float:
    sim = face.simulator(None)
    for _ in range(steps):
        sim.advance(H)
    size = np.linalg.norm(np.ptp(face.skin.points, axis=0))
    return float(np.abs(sim.x - face.skin.points).max() / size)


def step_response(face, dt: float | None) -> tuple[float, float]:
    states = list(face.simulate("surprise", 0.6, dt))
    w = np.array([np.abs(s.W).sum() for s in states])
    t = np.array([s.time for s in states])
    return float(t[np.argmax(w >= 0.9 * w[-1])]), float(w.max() / w[-1] - 1.0)


def halving(face) -> float:
    acts = face.activations_for("surprise")

    def ramp(t):
        k = min(1.0, t / 0.4)
        return {m: a * k for m, a in acts.items()}

    def trajectory(dt):
        sim = face.simulator(ramp)
        out = {}
        while sim.time < 1.0 - 1e-9:
            sim.advance(dt)
            out[round(sim.time, 6)] = sim.x - face.skin.points
        return out

    coarse, fine = trajectory(H), trajectory(H / 2.0)
    scale = max(np.abs(d).max() for d in fine.values())
    return float(max(np.abs(coarse[t] - fine[t]).max() for t in coarse) / scale)


def energy_rises(face, steps: int = 60) -> int:
    sim = face.simulator(None)
    sim.x = face.physical_skin().equilibrium(
        face.muscle_displacement(face.activations_for("surprise")))
    energies = [sim.energy()]
    for _ in range(steps):
        sim.advance(H)
        energies.append(sim.energy())
    e = np.array(energies)
    return int(np.count_nonzero(np.diff(e) > 1e-12 * e[0]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--face", default="procedural")
    ap.add_argument("--triangles", type=int, default=None)
    args = ap.parse_args()
    print(f"load average {open('/proc/loadavg').read().split()[0]}")
    face = wv.datasets.load_face(args.face, args.triangles)
    print(f"{args.face}: {face.skin.n_triangles} triangles, {face.skin.n_points} vertices")
    t0 = time.perf_counter()
    print(f"  drift after 1,000 steps at rest: {drift(face):.1e} of the size "
          f"[{time.perf_counter() - t0:.0f} s]", flush=True)
    for dt in (0.01, None):
        t0 = time.perf_counter()
        reach, over = step_response(face, dt)
        print(f"  step to surprise, dt {'1/30' if dt is None else dt} s: 90 % at "
              f"{1e3 * reach:.0f} ms, overshoot {over:.1%} [{time.perf_counter() - t0:.0f} s]",
              flush=True)
    t0 = time.perf_counter()
    print(f"  halving the step, 1 s ramp: {halving(face):.2%} of the largest displacement "
          f"[{time.perf_counter() - t0:.0f} s]", flush=True)
    t0 = time.perf_counter()
    print(f"  free damped skin from the surprise equilibrium: energy rose in "
          f"{energy_rises(face)} of 60 steps [{time.perf_counter() - t0:.0f} s]", flush=True)


if __name__ == "__main__":
    main()
