"""
The real head
=============

The built-in muscle layout moved onto a scanned head, Lee Perry-Smith's (CC BY 3.0,
Infinite Realities), with the nine landmarks that
``wrinkle_vis/datasets/examples/lee_perry_smith.json`` records. The scan is not shipped:
it is read from ``$WRINKLE_VIS_REALMESHES`` (the documentation build points that at the
workspace's ``shared/realmeshes``); without it this example says so and shows nothing.
"""

import os
from pathlib import Path

import wrinkle_vis as wv

scan = Path(os.environ.get("WRINKLE_VIS_REALMESHES", "realmeshes")) / "lee_perry_smith_head.obj"
layout = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"

if not scan.is_file():
    print(f"The scan is not here ({scan}); nothing to show.")
    head = None
else:
    head = wv.datasets.load_face(skin=scan, layout=layout)
    print(f"{head.skin.n_points} vertices, {len(head.muscles)} muscles")

# %%
# Surprise on the scan, refined, as plain skin: the forehead furrows of the paper's Fig. 9.
if head is not None:
    head.plot("surprise", None, refine=True, camera="forehead")

# %%
# Its wrinkle amplitude W (in the scan's units, metres).
if head is not None:
    head.plot("frown", "W", camera="upper_face")
