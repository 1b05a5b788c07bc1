"""The one timing rule of the benchmarks: medians of medians."""

import statistics
import time


def median_seconds(fn, calls: int, rounds: int) -> float:
    """Median over ``rounds`` of the median seconds of ``calls`` calls of ``fn``."""
    per_round = []
    for _ in range(rounds):
        times = []
        for _ in range(calls):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        per_round.append(statistics.median(times))
    return statistics.median(per_round)


def alternating(runs: dict, calls: list, rounds: int, timed, same) -> dict:
    """Two implementations ``runs`` (``{"new": f, "old": g}``) on the same captured
    ``calls``, taking turns call by call (the order flipped every round): per call, the
    medians over ``rounds`` of the mean wall and CPU milliseconds (``new_wall``,
    ``old_cpu``, ...), and whether every call's outputs were ``same(new, old)``.

    ``timed(fn, call)`` calls ``fn`` on (a fresh copy of) one call's arguments and returns
    ``(wall s, CPU s, out)``.
    """
    wall: dict = {k: [] for k in runs}
    cpu: dict = {k: [] for k in runs}
    alike = True
    for r in range(rounds):
        tot = {k: [0.0, 0.0] for k in runs}
        for call in calls:
            outs = {}
            for k in (("new", "old") if r % 2 == 0 else ("old", "new")):
                w, c, outs[k] = timed(runs[k], call)
                tot[k][0] += w
                tot[k][1] += c
            alike &= bool(same(outs["new"], outs["old"]))
        for k in runs:
            wall[k].append(tot[k][0] / max(len(calls), 1) * 1e3)
            cpu[k].append(tot[k][1] / max(len(calls), 1) * 1e3)
    return {"calls": len(calls), "same": alike,
            **{f"{k}_wall": statistics.median(v) for k, v in wall.items()},
            **{f"{k}_cpu": statistics.median(v) for k, v in cpu.items()}}


def alternating_line(case: str, what: str, v: dict, baseline: str) -> str:
    """One line of :func:`alternating`'s figures ``v``: ``case``, how many ``what`` were
    timed, wall (CPU) ms a call for this tree and ``baseline``, the CPU ratio, whether the
    outputs were bit for bit equal, and the load average."""
    import os

    return (f"{case} {v['calls']} {what}, wall (CPU) this {v['new_wall']:6.2f} "
            f"({v['new_cpu']:6.2f}) ms, {baseline} {v['old_wall']:6.2f} ({v['old_cpu']:6.2f}) "
            f"ms, ratio {v['new_cpu'] / max(v['old_cpu'], 1e-9):.2f}; bit for bit "
            f"{'equal' if v['same'] else 'DIFFERENT'} [load {os.getloadavg()[0]:.2f}]")


def refined_parser(doc: str, baseline: str):
    """The refined benches' shared options: ``--baseline`` (default ``baseline``),
    ``--frames``, ``--rounds`` and ``--skin-model``; each bench adds its own."""
    import argparse

    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--baseline", default=baseline)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--skin-model", default="both", choices=("geometric", "physical", "both"))
    return ap
