"""The head's frame time with its lips separated (the shipped skin) against the scan's lips
(a baseline ``lee_perry_smith.npz``, by default main's, read with ``git show``): the same
code, the same muscles, only the rest skin differs. Unrefined frames at intensity 1, the fold
guard on, each face's rest radii and pull terms warmed before timing; the two faces are timed
one after the other, expression by expression.

Run:  .venv/bin/python benchmarks/bench_head_lips.py [--baseline main] [--rounds 5]

Every figure is the median over ``--rounds`` rounds of the median of several calls.
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
from pathlib import Path

import numpy as np
from _timing import median_seconds

ROOT = Path(__file__).resolve().parents[1]


def face_from(data: dict):
    """The head built from the arrays ``data`` of a ``lee_perry_smith.npz``."""
    from wrinkle_vis.core import FaceModel, TriangleSurface, load_layout
    from wrinkle_vis.datasets import lee_perry_smith as lps

    skin = TriangleSurface(data["skin_points"].astype(float),
                           data["skin_triangles"].astype(np.intp))
    skull = TriangleSurface(data["skull_points"].astype(float),
                            data["skull_triangles"].astype(np.intp))
    lay = load_layout(lps.LAYOUT)
    return FaceModel(skin, skull, lay.muscles, lay.expressions, name=lay.name,
                     landmarks=lay.landmarks, unit="mm", mapping=lay.mapping)


def baseline_arrays(rev: str) -> dict:
    """The arrays of ``datasets/lee_perry_smith.npz`` at git revision ``rev``."""
    blob = subprocess.run(["git", "show", f"{rev}:datasets/lee_perry_smith.npz"], cwd=ROOT,
                          capture_output=True, check=True).stdout
    with np.load(io.BytesIO(blob)) as data:
        return {k: data[k] for k in data.files}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    from wrinkle_vis.datasets import lee_perry_smith as lps

    with np.load(lps.DATA) as data:
        faces = {"separated lips": face_from({k: data[k] for k in data.files}),
                 f"{args.baseline}'s lips": face_from(baseline_arrays(args.baseline))}
    names = tuple(next(iter(faces.values())).expressions)
    for face in faces.values():  # warm the rest radii and pull terms
        for name in names:
            face.evaluate(name, 1.0)
    print(f"load average {os.getloadavg()[0]:.2f}")
    for name in names:
        row = [median_seconds(lambda f=face, n=name: f.evaluate(n, 1.0), 3, args.rounds)
               for face in faces.values()]
        print(f"{name:18s} " + "  ".join(f"{label} {1e3 * t:7.2f} ms"
                                          for label, t in zip(faces, row, strict=True))
              + f"  ratio {row[0] / row[1]:.2f}")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
