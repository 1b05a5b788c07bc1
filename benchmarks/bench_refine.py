"""Frame time of ``evaluate(..., refine=True)`` at the paper's size (one core).

Run:  OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_refine.py [--rounds 5]

Reports the first refined frame (which builds and caches the refined skins) and the median
of later frames of the same expression (the refined skins reused), against the unrefined
frame. The fidelity comparison with VTK's uniform subdivision is not here yet.
"""

import argparse
import statistics
import time

import wrinkle_vis as wv


def median_ms(fn, calls=50, rounds=5):
    out = []
    for _ in range(rounds):
        times = []
        for _ in range(calls):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        out.append(statistics.median(times))
    return 1e3 * statistics.median(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    face = wv.datasets.load_face()
    for name in ("surprise", "frown", "fear"):
        t0 = time.perf_counter()
        state = face.evaluate(name, refine=True)
        first = 1e3 * (time.perf_counter() - t0)
        refined = median_ms(lambda n=name: face.evaluate(n, refine=True), rounds=args.rounds)
        plain = median_ms(lambda n=name: face.evaluate(n), rounds=args.rounds)
        print(f"{name:9s} {face.skin.n_triangles} -> {len(state.triangles)} triangles: first "
              f"refined frame {first:.0f} ms, then {refined:.2f} ms (unrefined {plain:.3f} ms)")


if __name__ == "__main__":
    main()
