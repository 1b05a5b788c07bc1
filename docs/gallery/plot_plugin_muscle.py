"""
A plug-in muscle type
=====================

Muscle types are plug-ins: a package declares its type in the entry-point group
``wrinkle_vis.muscles`` and every part of wrinkle-vis (the model, layout files, the app's
widgets) finds it. ``wrinkle_vis_ring`` (in ``tests/plugins``) is an example: a ring muscle,
sphincter-like, which pulls the skin towards its centre and folds it into concentric rings.
See :doc:`/plugins` for how to write one.
"""

import numpy as np

import wrinkle_vis as wv

print("muscle types:", ", ".join(wv.muscle_types()))
Ring = wv.get_muscle_type("ring")  # found through its entry point

# %%
# A ring around the mouth (an orbicularis oris of sorts), added to the built-in face.
face = wv.datasets.load_face()
left, right = (np.asarray(face.landmarks[k]) for k in ("mouth_corner_L", "mouth_corner_R"))
center = 0.5 * (left + right)
radius = 0.8 * float(np.linalg.norm(left - right))
ring = Ring("orbicularis_oris", center=tuple(center), axis=(0.0, 0.0, 1.0), radius=radius,
            depth=15.0, lambda_w=0.1, n_wrinkles=3, k0=1.5, alpha=1.0, strength=0.35 * radius)
face = face.with_muscle(ring)
state = face.evaluate({"orbicularis_oris": 1.0})
print(f"W != 0 at {np.count_nonzero(state.W)} vertices, |W| <= {np.abs(state.W).max():.2f} mm")

# %%
# Its wrinkles, refined: W, then plain skin.
face.plot({"orbicularis_oris": 1.0}, "W", refine=True, camera="front")

# %%
face.plot({"orbicularis_oris": 1.0}, None, refine=True, camera="front")

# %%
# Its fields are the same as any muscle's: here the compression.
state.plot("eps", "orbicularis_oris", camera="front")
