"""Recorded tracks: reading the real OpenFace file, and the per-frame cost of playing it
(``face.play``, unrefined, paper size) side by side with evaluating an expression's ramp at
the same number of frames (``face.evaluate(expression.at(t))``, the app's playback path).

Run:  .venv/bin/python benchmarks/bench_tracks.py [--rounds 5]

Every figure is the median over ``--rounds`` rounds of the median of several calls.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
from _timing import median_seconds

import wrinkle_vis as wv

OPENFACE = Path(__file__).resolve().parents[1].parent / "shared" / "tracks" / \
    "openface_test.csv"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        face = wv.datasets.load_face().with_skin_model("geometric")
    read = median_seconds(lambda: wv.read_track(OPENFACE), 3, args.rounds)
    track = wv.read_track(OPENFACE)
    n = track.n_frames
    for _ in face.play(track):  # warm the caches of the muscles the track drives
        pass
    play = median_seconds(lambda: [s.W for s in face.play(track)], 1, args.rounds) / n
    ramp = face.expressions["surprise"]
    times = np.linspace(0.0, ramp.duration_s, n)
    for t in times:
        face.evaluate(ramp.at(t))

    def expression():
        return [face.evaluate(ramp.at(t)).W for t in times]

    base = median_seconds(expression, 1, args.rounds) / n
    print(f"read {OPENFACE.name} ({n} frames, {len(track.channels)} AUs): {1e3 * read:.1f} ms")
    print(f"face.play, per frame ({face.skin.n_triangles} triangles, unrefined): "
          f"{1e3 * play:.2f} ms ({1 / play:.0f} frames/s)")
    print(f"surprise ramp, per frame (baseline): {1e3 * base:.2f} ms ({1 / base:.0f} frames/s)")


if __name__ == "__main__":
    main()
