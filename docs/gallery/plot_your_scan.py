"""
Your own scan
=============

Any triangle mesh of a face (OBJ, PLY, STL, VTP, VTK or what meshio reads) takes the
built-in muscles: give ``load_face`` the file and a few landmarks on it (nasion, nose tip,
chin, the eyes' and the mouth's corners), and the layout is moved onto it
(:func:`~wrinkle_vis.datasets.scans.transfer_layout`). A scan in other units, turned and
moved, works the same.

Here the "scan" is made on the spot: the built-in skin at another resolution, in metres,
turned by 20 degrees and moved, written to a PLY file, as a scanner would give it.
"""

import tempfile
from pathlib import Path

import numpy as np
import pyvista as pv

import wrinkle_vis as wv

turn = np.radians(20.0)
rotation = np.array([[np.cos(turn), 0.0, np.sin(turn)], [0.0, 1.0, 0.0],
                     [-np.sin(turn), 0.0, np.cos(turn)]])


def to_scan(points):
    """Millimetres to the scan's frame: metres, turned about y, moved."""
    return np.asarray(points) / 1000.0 @ rotation.T + np.array([0.1, 1.6, -0.3])


skin = wv.datasets.build_skin(6000)
mesh = pv.PolyData(to_scan(skin.points),
                   faces=np.hstack([np.full((skin.n_triangles, 1), 3), skin.triangles]))
path = Path(tempfile.mkdtemp()) / "my_scan.ply"
mesh.save(path)
# where you would click the landmarks on your scan
landmarks = {k: tuple(to_scan(v)) for k, v in wv.datasets.builtin_landmarks().items()}
print(f"{path.name}: {mesh.n_points} points; landmarks: {', '.join(landmarks)}")

# %%
# Load it: the layout follows the landmarks, a closed skull is built under the skin at the
# regional tissue depth. The unit is the scan's (guessed from its size, with a warning,
# when not given).
face = wv.datasets.load_face(skin=path, landmarks=landmarks, unit="m")
print(f"{len(face.muscles)} muscles, expressions: {', '.join(face.expressions)}")

# %%
# Surprise on the scan (the camera frames the face by its landmarks).
face.plot("surprise", "W", camera="forehead")

# %%
# Frown, refined, as plain skin.
face.plot("frown", None, refine=True, camera="upper_face")
