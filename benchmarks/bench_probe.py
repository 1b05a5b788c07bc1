"""The app's probe per frame: the fields at the probed point read from the compact
per-muscle data (``FaceState.values_at``, what ``Session.probe`` does) beside the way it was
(every muscle's every field built full length, then read at the point's triangle).

Run:  .venv/bin/python benchmarks/bench_probe.py [--triangles 4500] [--frames 15] [--rounds 3]

Wall clock and CPU time (``time.process_time``: on a machine busy with other work, a wall
time also counts the waits for a core, most after the evaluation's burst). Each timed call
gets a frame of its own (``--frames`` intensities played round and round,
each frame evaluated anew before the clock starts), so neither way finds the other's fields
built. Medians of the frames of a round, median over ``--rounds`` rounds, the two ways
interleaved frame by frame; unrefined and refined. Also checks that both ways give the same
numbers.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import wrinkle_vis as wv
from wrinkle_vis.app.session import FIELD_NAMES, Session, _interpolated


def probe_full(session: Session, where) -> dict:
    """The probe as it was before issue 28: every field full length, read at 3 vertices."""
    state, corners, weights = session._located(where)
    out = {"total": {"W": _interpolated(state.W[corners], weights)}}
    for name in session.face.muscle_names:
        fields = state.fields[name]
        values = {f: _interpolated(fields[f][corners], weights) for f in FIELD_NAMES}
        if any(np.isfinite(v) for v in values.values()):
            out[name] = values
    return out


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        np.array_equal(list(a[k].values()), list(b[k].values()), equal_nan=True) for k in a)


def timed(session: Session, where, frames: int, rounds: int) -> dict[str, float]:
    """Median ms a frame of each way, wall clock and CPU time of this process (which a
    loaded machine's waits for a core do not inflate), and of the frame's evaluation for
    scale, playing ``frames`` intensities round and round as Play does (a first round, not
    timed, lets the refinement's hierarchy grow to what they need).
    """
    ways = {"compact": session.probe, "full": lambda w: probe_full(session, w)}
    intensities = np.linspace(0.4, 1.0, frames)
    keys = [f"{k} {c}" for k in (*ways, "evaluate") for c in ("wall", "cpu")]
    rounds_ms: dict[str, list[float]] = {k: [] for k in keys}
    for r in range(rounds + 1):
        per: dict[str, list[float]] = {k: [] for k in keys}
        for intensity in intensities:
            for name, way in ways.items():
                session.set_intensity(intensity)
                session._state = None  # a new frame: nothing built in it
                t0, c0 = time.perf_counter(), time.process_time()
                state = session.state()
                t1, c1 = time.perf_counter(), time.process_time()
                assert not any(state.fields[m]._cache for m in session.face.muscle_names)
                way(where)
                t2, c2 = time.perf_counter(), time.process_time()
                per[f"{name} wall"].append(1e3 * (t2 - t1))
                per[f"{name} cpu"].append(1e3 * (c2 - c1))
                per["evaluate wall"].append(1e3 * (t1 - t0))
                per["evaluate cpu"].append(1e3 * (c1 - c0))
        for k, v in per.items():
            if r:  # the first round warms up
                rounds_ms[k].append(statistics.median(v))
    return {k: statistics.median(v) for k, v in rounds_ms.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=4500)
    parser.add_argument("--frames", type=int, default=15)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    face = wv.datasets.load_face(args.triangles)
    session = Session(face)
    session.set_expression("fear")
    region = face.muscle_data(face.muscle("frontalis_major_L")).region
    tri = int(np.flatnonzero((face.skin.triangles == region[len(region) // 2]).any(1))[0])
    from wrinkle_vis.app.session import SurfacePoint

    where = SurfacePoint(tri, (0.2, 0.3, 0.5))  # inside a triangle: interpolated
    print(f"{face.skin.n_triangles} triangles, {len(face.muscles)} muscles, "
          f"{len(FIELD_NAMES)} fields; load average {os.getloadavg()[0]:.2f}")
    for refine in (False, True):
        session.set_refine(refine)
        session.set_intensity(0.9)
        assert _same(session.probe(where), probe_full(session, where))
        session.set_intensity(0.91)
        ms = timed(session, where, args.frames, args.rounds)
        for c in ("wall", "cpu"):
            print(f"{'refined' if refine else 'unrefined':9s} {c:4s}: probe "
                  f"{ms[f'compact {c}']:.3f} ms (compact) vs {ms[f'full {c}']:.3f} ms (full "
                  f"fields), {ms[f'full {c}'] / ms[f'compact {c}']:.0f}x; evaluation "
                  f"{ms[f'evaluate {c}']:.2f} ms")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
