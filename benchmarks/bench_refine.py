"""Frame time of ``evaluate(..., refine=True)`` at the paper's size (one core).

Run:  OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_refine.py [--rounds 5]

Reports the first refined frame (which builds and caches the refined skins) and the median
of later frames of the same expression (the refined skins reused), against the unrefined
frame. The fidelity comparison with VTK's uniform subdivision is not here yet.
"""

import argparse
import time

from _timing import median_seconds

import wrinkle_vis as wv


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    face = wv.datasets.load_face()
    for name in ("surprise", "frown", "fear"):
        t0 = time.perf_counter()
        state = face.evaluate(name, refine=True)
        first = 1e3 * (time.perf_counter() - t0)
        refined = 1e3 * median_seconds(lambda n=name: face.evaluate(n, refine=True), 50,
                                       args.rounds)
        plain = 1e3 * median_seconds(lambda n=name: face.evaluate(n), 50, args.rounds)
        print(f"{name:9s} {face.skin.n_triangles} -> {len(state.triangles)} triangles: first "
              f"refined frame {first:.0f} ms, then {refined:.2f} ms (unrefined {plain:.3f} ms)")


if __name__ == "__main__":
    main()
