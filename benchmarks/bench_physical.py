"""The physically based skin's frame against the geometric frame and a peer solver.

For each face size: one simulated frame (a 1/30 s step of ``Simulation.step``, fields
included, unrefined) during a step to surprise; the geometric frame (``face.evaluate``) in
the same run; the first simulated frame of a face just built (muscle data and factorization
included); the still frame (``evaluate(skin="physical")``); and a peer, a plain
semi-implicit (symplectic Euler) mass-spring with the same springs, masses and damping, at
the largest step it is stable at (0.9 of 2 / omega_max, omega_max from the largest
eigenvalue of M^-1 K), advanced through the same 1/30 s.

Run:  .venv/bin/python benchmarks/bench_physical.py [--triangles 4500 20000] [--rounds 5]
      [--memory 10000 [--memory-only]]

``--memory N`` also runs N simulated frames of the first face (the command switching
between surprise, frown, fear and neutral every 100 frames) and prints the resident memory
every N/20 frames (it should stay flat); ``--memory-only`` skips the timings. ``--face
lee_perry_smith`` times the scanned head instead of the procedural face.

Every figure is the median over ``--rounds`` rounds of the median of several calls.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from _timing import median_seconds

import wrinkle_vis as wv

H = 1.0 / 30.0


def cpu_seconds(fn, calls: int, rounds: int) -> float:
    """Median over ``rounds`` of the mean process CPU seconds of ``calls`` calls of ``fn``
    (what a frame costs on a core of its own, when the machine is shared)."""
    per_round = []
    for _ in range(rounds):
        t0 = time.process_time()
        for _ in range(calls):
            fn()
        per_round.append((time.process_time() - t0) / calls)
    return float(np.median(per_round))


def fresh(face):
    """The same face with no caches (as just loaded)."""
    return wv.FaceModel(face.skin, face.skull, face.muscles, face.expressions, name=face.name,
                        unit=face.unit)


class Explicit:
    """Semi-implicit Euler on the same springs (the biphasic law included), attachments and
    zone springs, and mass-proportional damping."""

    def __init__(self, springs):
        self.s = springs
        stiff = springs.laplacian + sp.diags(springs.anchor)
        lam = spla.eigsh(sp.diags(1.0 / springs.mass) @ stiff, k=1, which="LM",
                         return_eigenvectors=False)[0]
        self.omega = math.sqrt(lam)
        self.h = 0.9 * 2.0 / self.omega
        self.substeps = math.ceil(H / self.h)

    def force(self, x, target):
        s = self.s
        d = x[s.i] - x[s.j]
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        ne, c, L = s.n_edges, s.material.biphasic_strain, s.L[: s.n_edges]
        mag = s.k * (length - s.L)
        mag[:ne] += s.kb * (length[:ne] - np.clip(length[:ne], L * (1 - c), L * (1 + c)))
        f = -(s.J @ (d * (mag / np.maximum(length, 1e-300))[:, None]))
        f -= s.anchor[:, None] * (x - s.rest) - s.k_zone[:, None] * target
        return f

    def frame(self, x, v, target):
        h = H / self.substeps
        inv_m = (1.0 / self.s.mass)[:, None]
        c = self.s.material.damping
        for _ in range(self.substeps):
            v = (v + h * inv_m * self.force(x, target)) / (1.0 + h * c)
            x = x + h * v
        return x, v


def run(n_triangles: int | None, rounds: int, name: str = "procedural") -> dict:
    face = wv.datasets.load_face(name, n_triangles)
    out = {"triangles": face.skin.n_triangles, "vertices": face.skin.n_points}
    face.evaluate("surprise")
    out["geometric_frame_ms"] = 1e3 * median_seconds(lambda: face.evaluate("surprise"), 10,
                                                      rounds)
    out["geometric_frame_cpu_ms"] = 1e3 * cpu_seconds(lambda: face.evaluate("surprise"), 10,
                                                      rounds)
    # first simulated frame of a face as loaded: muscle data, factorization, the step
    first = []
    for _ in range(max(3, rounds // 2)):
        f2 = fresh(face)
        t0 = time.perf_counter()
        f2.simulator("surprise").step(H)
        first.append(time.perf_counter() - t0)
    out["first_frame_s"] = float(np.median(first))
    fact = []
    for _ in range(max(3, rounds // 2)):
        springs = face.physical_skin()
        springs._factors.clear()
        t0 = time.perf_counter()
        springs._factor(H)
        fact.append(time.perf_counter() - t0)
    out["factorize_ms"] = 1e3 * float(np.median(fact))
    sim = face.simulator("surprise")
    for _ in range(3):
        sim.step(H)

    def frame():
        if sim.time > 2.0:
            sim.reset()
        sim.step(H)

    out["physical_frame_ms"] = 1e3 * median_seconds(frame, 10, rounds)
    out["physical_frame_cpu_ms"] = 1e3 * cpu_seconds(frame, 10, rounds)
    springs = face.physical_skin()
    target = face.muscle_displacement(face.activations_for("surprise"))
    x, v = sim.x.copy(), sim.v.copy()
    out["physical_solver_ms"] = 1e3 * median_seconds(lambda: springs.step(x, v, target, H), 10,
                                                      rounds)
    t0 = time.perf_counter()
    face.evaluate("surprise", skin="physical")
    out["still_frame_s"] = time.perf_counter() - t0
    peer = Explicit(springs)
    out["peer_stable_step_us"] = 1e6 * peer.h
    out["peer_substeps"] = peer.substeps
    xe, ve = springs.rest.copy(), np.zeros_like(springs.rest)
    out["peer_frame_ms"] = 1e3 * median_seconds(lambda: peer.frame(xe, ve, target), 2,
                                                 max(1, rounds // 2))
    return out


def memory(n_triangles: int, frames: int) -> None:
    """Resident memory over ``frames`` simulated frames (the command cycling through
    surprise, frown, fear and neutral every 100 frames), printed 20 times; the growth from
    the first tenth of the run to its end is the figure to watch.
    """
    import resource

    face = wv.datasets.load_face(n_triangles=n_triangles)
    names = ("surprise", "frown", "fear", None)
    sim = face.simulator(names[0])
    every = max(1, frames // 20)
    seen = []
    t0 = time.perf_counter()
    for k in range(frames):
        if k % 100 == 0:
            sim.timeline = names[(k // 100) % len(names)]
        sim.step(H)
        if (k + 1) % every == 0:
            seen.append((k + 1, _rss_mb()))
            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            print(f"  frame {k + 1:6d}: resident {seen[-1][1]:7.1f} MB (peak {peak:.1f} MB; "
                  f"{time.perf_counter() - t0:.0f} s)", flush=True)
    after = [rss for k, rss in seen if k >= frames // 10]
    print(f"  from frame {frames // 10} to {frames}: {min(after):.1f}-{max(after):.1f} MB, "
          f"growth {after[-1] - after[0]:+.1f} MB")


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * (__import__("os").sysconf("SC_PAGE_SIZE")) / 2**20


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, nargs="+", default=[4500, 20000])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--memory", type=int, default=0, metavar="N",
                    help="also run N frames of the first face and print resident memory")
    ap.add_argument("--face", default="procedural",
                    help="built-in face (procedural, or lee_perry_smith: --triangles ignored)")
    ap.add_argument("--memory-only", action="store_true",
                    help="with --memory: skip the timings")
    args = ap.parse_args()
    print(f"load average {open('/proc/loadavg').read().split()[0]}, "
          f"{__import__('os').cpu_count()} CPUs")
    sizes = args.triangles if args.face == "procedural" else [None]
    for n in [] if args.memory_only else sizes:
        r = run(n, args.rounds, args.face)
        print(f"{args.face}, {r['triangles']} triangles, {r['vertices']} vertices:")
        print(f"  geometric frame           {r['geometric_frame_ms']:8.2f} ms "
              f"(CPU {r['geometric_frame_cpu_ms']:.2f} ms)")
        print(f"  physical frame (1/30 s)   {r['physical_frame_ms']:8.2f} ms "
              f"(CPU {r['physical_frame_cpu_ms']:.2f} ms; solver alone "
              f"{r['physical_solver_ms']:.2f} ms)")
        print(f"  first physical frame      {r['first_frame_s']:8.3f} s "
              f"(factorization {r['factorize_ms']:.1f} ms)")
        print(f"  still frame (equilibrium) {r['still_frame_s']:8.3f} s")
        print(f"  peer: semi-implicit Euler {r['peer_frame_ms']:8.2f} ms a frame "
              f"({r['peer_substeps']} substeps of {r['peer_stable_step_us']:.1f} us)")
    if args.memory:
        print(f"memory over {args.memory} frames, {args.triangles[0]} triangles:")
        memory(args.triangles[0], args.memory)


if __name__ == "__main__":
    main()
