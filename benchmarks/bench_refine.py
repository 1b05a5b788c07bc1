"""Refined frames of a changing expression: what an animation meets (issue: dynamic wrinkles).

Run:  OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_refine.py [--rounds 5]
      [--triangles 4500] [--memory FRAMES] [--steps 30]

For each of surprise, frown and fear, an intensity ramp from 0 to 1 in ``--steps`` steps,
every frame with ``refine=True`` (so nearly every frame splits another set of triangles),
side by side with the same ramp unrefined (the peer). Reports the median frame (median over
rounds of each round's median, after one ramp that builds the hierarchy), the worst frame
over its median, the first refined frame
of a freshly loaded face (and the first unrefined one, which builds the per-muscle data), and
the ramp right after loading (the first play of the expression, while the subdivision
hierarchy is built: median, worst and all frames).

Popping: between consecutive frames, how far the refined surface moves at a material point
(a vertex of the later frame, and where the earlier refined surface was at that rest point:
its own vertex there, or the straight edge it split) against how far the unrefined surface's
vertices move and the refinement's own error (the largest distance from a new vertex to the
straight edge it splits, in either frame).

``--memory N``: N refined frames with intensity and expression changing, resident memory
after each thousand (the engine keeps its caches within ``REFINE_CACHE_BYTES``).
"""

import argparse
import gc
import os
import statistics
import time

import numpy as np

import wrinkle_vis as wv

EXPRESSIONS = ("surprise", "frown", "fear")


def rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def ramp(face, name, steps, refine):
    times, states = [], []
    for i in range(steps + 1):
        t0 = time.perf_counter()
        state = face.evaluate(name, i / steps, refine=refine)
        times.append(time.perf_counter() - t0)
        states.append(state)
    return times, states


def hierarchy_ids(face):
    engine = face._rest.engine(3)
    return engine.last[2] if engine.last is not None else np.arange(face.skin.n_points)


def popping(face, name, steps):
    """Largest material-point move of the refined surface per frame pair, the unrefined
    vertices' largest move, and the refinement's largest own error."""
    hier = face._rest.engine(3).hier
    frames = []
    for i in range(steps + 1):
        s = face.evaluate(name, i / steps, refine=True)
        ids = hierarchy_ids(face) if len(s.points) > face.skin.n_points else \
            np.arange(face.skin.n_points)
        frames.append((ids.copy(), np.array(s.points)))
    plain = [np.array(face.evaluate(name, i / steps).points) for i in range(steps + 1)]
    pops, moves, errors = [], [], []
    for k in range(steps):
        (ids0, x0), (ids1, x1) = frames[k], frames[k + 1]
        at0 = _surface_at(hier, ids0, x0, ids1)
        pops.append(np.linalg.norm(x1 - at0, axis=1).max())
        moves.append(np.linalg.norm(plain[k + 1] - plain[k], axis=1).max())
        errors.append(max(_error(hier, ids0, x0), _error(hier, ids1, x1)))
    return np.array(pops), np.array(moves), np.array(errors)


def _positions(hier, ids, x):
    pos = np.full((hier.n_points, 3), np.nan)
    pos[ids] = x
    return pos


def _surface_at(hier, ids, x, query):
    """Where the refined surface (vertices ``ids`` at ``x``) is at the rest points of the
    hierarchy vertices ``query``: its own vertex, else the straight edge's middle."""
    pos = _positions(hier, ids, x)
    for level in range(1, hier.depth + 1):  # fill coarse to fine
        v = np.flatnonzero((hier.level == level) & np.isnan(pos[:, 0]))
        pos[v] = 0.5 * (pos[hier.ring[v, 0]] + pos[hier.ring[v, 3]])
    return pos[query]


def _error(hier, ids, x):
    pos = _positions(hier, ids, x)
    new = ids[ids >= hier.n_root]
    if not len(new):
        return 0.0
    mid = 0.5 * (pos[hier.ring[new, 0]] + pos[hier.ring[new, 3]])
    return float(np.nanmax(np.linalg.norm(pos[new] - mid, axis=1)))


def first_frames(n_triangles, name):
    face = wv.datasets.load_face(n_triangles=n_triangles).with_skin_model("geometric")
    t0 = time.perf_counter()
    face.evaluate(name)
    plain = time.perf_counter() - t0
    face = wv.datasets.load_face(n_triangles=n_triangles).with_skin_model("geometric")
    t0 = time.perf_counter()
    face.evaluate(name, refine=True)
    return plain, time.perf_counter() - t0


def first_ramp(n_triangles, name, steps):
    """The refined ramp right after loading (the unrefined frame already evaluated once):
    what the first play of an expression meets while the hierarchy is built."""
    face = wv.datasets.load_face(n_triangles=n_triangles).with_skin_model("geometric")
    face.evaluate(name)
    times, _ = ramp(face, name, steps, True)
    return times


def speed(args):
    face = wv.datasets.load_face(n_triangles=args.triangles).with_skin_model("geometric")
    print(f"face: {face.skin.n_triangles} triangles; ramp 0..1 in {args.steps} steps, "
          f"{args.rounds} rounds; refine_angle_deg 3, refine_levels 3")
    for name in EXPRESSIONS:
        plain_first, refined_first = first_frames(args.triangles, name)
        first = first_ramp(args.triangles, name, args.steps)
        med, worst, plain_med, sizes = [], [], [], []
        ramp(face, name, args.steps, True)  # the first play builds (timed above): warm up
        for _ in range(args.rounds):
            t, states = ramp(face, name, args.steps, True)
            med.append(statistics.median(t))
            worst.append(max(t[1:]))
            sizes.append(max(len(s.triangles) for s in states))
            p, _ = ramp(face, name, args.steps, False)
            plain_med.append(statistics.median(p))
        m, p = statistics.median(med), statistics.median(plain_med)
        print(f"{name:9s} refined median {1e3 * m:7.2f} ms, worst/median "
              f"{statistics.median(worst) / m:4.1f}, first refined frame "
              f"{1e3 * refined_first:6.1f} ms (first unrefined {1e3 * plain_first:5.1f} ms) | "
              f"unrefined median {1e3 * p:6.3f} ms, ratio {m / p:6.0f}x | up to "
              f"{max(sizes)} triangles")
        print(f"{'':9s} first ramp after loading: median {1e3 * statistics.median(first):.1f} "
              f"ms, worst {1e3 * max(first):.1f} ms, all {len(first)} frames "
              f"{1e3 * sum(first):.0f} ms")
        if args.triangles <= 20000:
            pops, moves, errors = popping(face, name, args.steps)
            excess = pops - (moves + errors)
            print(f"{'':9s} popping: refined surface moves at most {pops.max():.3f}, "
                  f"unrefined vertices {moves.max():.3f}, refinement error up to "
                  f"{errors.max():.3f}; move - (unrefined move + error) at most "
                  f"{excess.max():+.3f} (face units)")


def memory(args):
    face = wv.datasets.load_face(n_triangles=args.triangles).with_skin_model("geometric")
    rng = np.random.default_rng(0)
    print(f"face: {face.skin.n_triangles} triangles; {args.memory} refined frames, "
          f"expression and intensity changing")
    start = rss_mb()
    t0 = time.perf_counter()
    for i in range(args.memory):
        name = EXPRESSIONS[(i // 50) % 3]
        face.evaluate(name, float(rng.uniform(0.05, 1.0)), refine=True)
        if (i + 1) % 1000 == 0:
            gc.collect()
            engine = face._rest.engine(3)
            print(f"  after {i + 1:6d} frames: {rss_mb():7.1f} MB resident (start "
                  f"{start:.1f}); engine cache {engine.cache.total / 2**20:.1f} MB, "
                  f"hierarchy {engine.hier.n_points} vertices; "
                  f"{1e3 * (time.perf_counter() - t0) / (i + 1):.1f} ms a frame", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=30)
    parser.add_argument("--triangles", type=int, default=4500)
    parser.add_argument("--memory", type=int, default=0)
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    if args.memory:
        memory(args)
    else:
        speed(args)


if __name__ == "__main__":
    main()
