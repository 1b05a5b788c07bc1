"""Rewrite datasets/lee_perry_smith.npz and datasets/lee_perry_smith.json from the scan.

Usage: python scripts/write_lee_perry_smith.py [../shared/realmeshes/lee_perry_smith_head.obj]

The scan ("Infinite, 3D Head Scan" by Lee Perry-Smith / Infinite Realities, CC BY 3.0) is
read and welded (datasets.read_surface), its corner UVs read (plotting.bake.read_obj_uvs),
moved into the built-in frame in millimetres by the rotation of the similarity that takes
the procedural face's landmarks onto the scan's (datasets/examples/lee_perry_smith.json,
picked on a front view), its lips moved apart where they pass through each other at the
slit or fold flat onto each other at the corners (separate_lips), its eyelids and an ear
smoothed where they pass through themselves and the eyes' corners' flat folds opened a little
(untangle_eyelids), the mouth's corners' flat folds opened a little (open_mouth_corners),
and stored as float32; the skull is the level set of datasets.skull.scan_skull under the
skin with its lips separated (before the eyelids' and the corners' smoothing); the muscles
are the procedural layout moved by the landmarks (datasets.scans.transfer_layout), then the
frontalis sheets refitted to this forehead (fit_frontalis). The original OBJ is never copied
into the package.
"""

import dataclasses
import sys
from pathlib import Path

import numpy as np

import wrinkle_vis as wv
from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.datasets import BUILTIN_LAYOUT, read_surface, transfer_layout
from wrinkle_vis.datasets.eyelids import untangle
from wrinkle_vis.datasets.lee_perry_smith import DATA, LAYOUT
from wrinkle_vis.datasets.lips import facing_pairs, folded_pairs, separate_crossings
from wrinkle_vis.datasets.scans import similarity_transform
from wrinkle_vis.datasets.skull import scan_skull
from wrinkle_vis.plotting.bake import read_obj_uvs

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "realmeshes" / "lee_perry_smith_head.obj"
EXAMPLE = ROOT / "datasets" / "examples" / "lee_perry_smith.json"
NAME = "Lee Perry-Smith head (CC BY 3.0, Lee Perry-Smith / Infinite Realities)"


def to_builtin_frame(skin, landmarks):
    """The scan in mm in the built-in frame: x_mm = 1000 R^T (x - t)."""
    source = wv.datasets.builtin_landmarks()
    names = list(source)
    rot, _, shift = similarity_transform([source[n] for n in names],
                                         [landmarks[n] for n in names])

    def move(p):
        return 1000.0 * (np.asarray(p, float) - shift) @ rot

    return move


#: The lips' region: within this many mm of the mid-point of the mouth corners.
LIPS_RADIUS = 40.0
#: How far apart the lips' sheets are held where they crossed or folded onto each other, mm.
LIPS_GAP = 1.0
#: Then how far apart the lips are held across the slit wherever they face each other closer
#: than LIPS_GAP + 0.1 mm (the mouth's corners, where the pulls press them together), mm.
LIPS_SLIT = 1.8


def separate_lips(skin, marks):
    """The skin with the lips' sheets, which pass through each other at the closed mouth's
    slit and fold flat onto each other at its corners, moved apart
    (:func:`~wrinkle_vis.datasets.lips.separate_crossings`, float32 as stored), then held
    :data:`LIPS_SLIT` apart wherever they face each other across the slit closer than
    :data:`LIPS_GAP` + 0.1 mm (as far as 40 steps get, never crossing): the rest skin then
    crosses itself only at the eyelids and an ear.
    """
    mid = 0.5 * (np.asarray(marks["mouth_corner_L"]) + np.asarray(marks["mouth_corner_R"]))
    region = np.linalg.norm(skin.points - mid, axis=1) < LIPS_RADIUS
    tri = skin.triangles
    points = separate_crossings(skin.points, tri, region, gap=LIPS_GAP, folds=True)
    slit = facing_pairs(points, tri, region, LIPS_GAP + 0.1, max_cos=-0.8)
    points = separate_crossings(points, tri, region, gap=LIPS_SLIT, folds=True, hold=slit,
                                strict=False, max_steps=40)
    return wv.TriangleSurface(points, tri)


#: The eyes' region: within this many mm of the mid-point of each eye's corners.
EYES_RADIUS = 20.0
#: Umbrella steps on the vertices that crossed and the eyes' corners' flat folds once
#: nothing crosses (datasets/eyelids.py: room for the pulls and the refined surface).
EYELIDS_CLEARANCE = 4
#: Then umbrella steps on the eyes' corners' flat folds alone (the refined squint at 1: 22
#: pairs added at the left eye's outer corner after 0 such steps, 5 after 6 or 8, 9 after
#: 10 or 12, 14 after 16).
EYE_CORNER_STEPS = 8


def untangle_eyelids(skin, marks):
    """The skin with its eyelids (whose lower margins curl back through the lids at rest)
    and an ear smoothed by umbrella steps where they pass through themselves, then
    :data:`EYELIDS_CLEARANCE` steps more there and on the corners of the eyes' flat folds,
    then :data:`EYE_CORNER_STEPS` on those corners alone
    (:func:`~wrinkle_vis.datasets.eyelids.untangle`, float32 as stored): the rest skin then
    crosses itself nowhere.
    """
    eyes = np.zeros(skin.n_points, bool)
    for side in "LR":
        mid = 0.5 * (np.asarray(marks[f"eye_inner_{side}"])
                     + np.asarray(marks[f"eye_outer_{side}"]))
        eyes |= np.linalg.norm(skin.points - mid, axis=1) < EYES_RADIUS
    tri = skin.triangles
    hold = np.zeros(skin.n_points, bool)
    hold[tri[folded_pairs(skin.points, tri, eyes).ravel()].ravel()] = True
    points = untangle(skin.points, tri, clearance=EYELIDS_CLEARANCE, hold=hold)
    return wv.TriangleSurface(untangle(points, tri, clearance=EYE_CORNER_STEPS, hold=hold), tri)


#: The mouth's corners' region: within this many mm of each corner's landmark.
MOUTH_CORNER_RADIUS = 8.0
#: Umbrella steps on the mouth's corners' flat folds (the refined pucker at 0.25, Waters'
#: sadness at 0.5 and 0.75 and fear at 1 added 6, 11, 8 and 11 pairs there without them,
#: none after 2, 4 or 8).
MOUTH_CORNER_STEPS = 4


def open_mouth_corners(skin, marks):
    """The skin with the flat folds at the mouth's corners (triangles that share a vertex and
    face each other, :func:`~wrinkle_vis.datasets.lips.folded_pairs`, within
    :data:`MOUTH_CORNER_RADIUS` of a corner) smoothed by :data:`MOUTH_CORNER_STEPS`
    umbrella steps (:func:`~wrinkle_vis.datasets.eyelids.untangle`, float32 as stored),
    never crossing: the refined surface through them then leaves room for the pulls.
    """
    corners = np.zeros(skin.n_points, bool)
    for side in "LR":
        corners |= np.linalg.norm(skin.points - np.asarray(marks[f"mouth_corner_{side}"]),
                                  axis=1) < MOUTH_CORNER_RADIUS
    tri = skin.triangles
    hold = np.zeros(skin.n_points, bool)
    hold[tri[folded_pairs(skin.points, tri, corners).ravel()].ravel()] = True
    return wv.TriangleSurface(untangle(skin.points, tri, clearance=MOUTH_CORNER_STEPS,
                                       hold=hold), tri)


def compact(surface):
    """The surface as stored (float32 points), read back as float64."""
    return wv.TriangleSurface(surface.points.astype(np.float32).astype(float),
                              surface.triangles)


#: How much higher the frontalis' wrinkling region ends on this head than the similarity
#: puts it, mm: this forehead meets a fuller brow ridge, and a region reaching onto the
#: ridge's bulge adds a crest there (the crest count along a fibre must equal n_w).
FRONTALIS_END_RAISE = 8.0


def fit_frontalis(layout):
    """The frontalis sheets ending :data:`FRONTALIS_END_RAISE` higher: ``L`` and the fall's
    start shortened by it, the region's start (``lambda_w L``, under the hairline) kept.
    """
    muscles = []
    for m in layout.muscles:
        if m.name.startswith("frontalis"):
            start = m.lambda_w * m.length
            length = m.length - FRONTALIS_END_RAISE
            m = m.replace(length=length, lambda_w=start / length,
                          fall_start=min(m.fall_start, length) - FRONTALIS_END_RAISE)
        muscles.append(m)
    return dataclasses.replace(layout, muscles=tuple(muscles))


def main(path: Path) -> None:
    scan = read_surface(path)
    uvs = read_obj_uvs(path, scan)  # (m, 3, 2), corners of the welded triangles
    marks_m = wv.load_layout(EXAMPLE).landmarks
    move = to_builtin_frame(scan, marks_m)
    scanned = compact(scan.with_points(move(scan.points)))
    marks = {k: tuple(map(float, closest_points(scanned, move(v)[None])[0]))
             for k, v in marks_m.items()}
    lips = separate_lips(scanned, marks)
    skin = open_mouth_corners(untangle_eyelids(lips, marks), marks)
    # the skull of the lips' skin: the level set of the smoothed eyelids fills the sockets
    # behind them with bumps (34,716 triangles against 33,188), and a physical frame under
    # strong random pulls pressed a socket vertex no longer inside it at rest 0.012 mm in
    skull = compact(scan_skull(lips, marks))
    assert all(np.allclose(closest_points(skin, np.asarray(v)[None])[0], v)
               for v in marks.values()), "a landmark sits on the lips that moved"
    layout = transfer_layout(wv.load_layout(BUILTIN_LAYOUT), skin, marks, skull)
    layout = dataclasses.replace(fit_frontalis(layout), name=NAME, landmarks=marks, unit="mm",
                                 face="lee_perry_smith", skin=None, skull=None)
    uv_table, uv_index = np.unique(uvs.reshape(-1, 2).astype(np.float32), axis=0,
                                   return_inverse=True)
    tmp = DATA.with_suffix(".tmp.npz")
    np.savez_compressed(
        tmp, skin_points=skin.points.astype(np.float32),
        skin_triangles=skin.triangles.astype(np.uint32),
        skull_points=skull.points.astype(np.float32),
        skull_triangles=skull.triangles.astype(np.uint32),
        uv_table=uv_table, uv_index=uv_index.reshape(-1, 3).astype(np.uint32))
    tmp.replace(DATA)
    wv.save_layout(layout, LAYOUT)
    print(f"wrote {DATA} ({DATA.stat().st_size / 1e6:.2f} MB) and {LAYOUT}: skin "
          f"{skin.n_points} points, {skin.n_triangles} triangles, skull {skull.n_triangles} "
          f"triangles, {len(layout.muscles)} muscles")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else SOURCE)
