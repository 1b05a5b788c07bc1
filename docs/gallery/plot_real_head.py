"""
The real head
=============

The Lee Perry-Smith head, built in: ``wv.datasets.load_face("lee_perry_smith")``. A real
head scan ("Infinite, 3D Head Scan" by Lee Perry-Smith / Infinite Realities, CC BY 3.0,
shipped in a derived form: welded, in millimetres, in the built-in frame) with the
procedural face's 21 muscles placed on its anatomy from nine landmarks, and a closed skull
inside it.
"""

import wrinkle_vis as wv

head = wv.datasets.load_face("lee_perry_smith")
print(f"{head.skin.n_points} vertices, {len(head.muscles)} muscles, unit {head.unit}")

# %%
# Surprise, refined, as plain skin: the forehead furrows of the paper's Fig. 9.
head.plot("surprise", None, refine=True, camera="forehead")

# %%
# Frown's wrinkle amplitude W (mm): the furrows between the brows.
head.plot("frown", "W", camera="upper_face")
