"""
Each expression
===============

The built-in face has the paper's expressions (surprise, frown, fear), a smile and
neutral. Plain skin under a raking light shows the wrinkles as relief, the way they look;
``face.plot`` evaluates the expression and shows it.
"""

import wrinkle_vis as wv

face = wv.datasets.load_face()
print(", ".join(face.expressions))

# %%
# Surprise: the frontalis lifts the brows and folds the forehead into horizontal furrows.
face.plot("surprise", None, camera="upper_face")

# %%
# Frown: the corrugators pull the brows together; vertical furrows between them.
face.plot("frown", None, camera="upper_face")

# %%
# Fear: both at once.
face.plot("fear", None, camera="upper_face")

# %%
# Smile: the zygomatici pull the mouth's corners up and back.
face.plot("smile", None, camera="front")

# %%
# Any expression at any intensity, here surprise at half strength, coloured by the wrinkle
# amplitude W in millimetres (furrows blue, bulges red).
face.plot("surprise", "W", intensity=0.5, camera="forehead")
