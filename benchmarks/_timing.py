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
