r"""
Each field
==========

Every muscle defines nine fields on the skin (``state.fields[muscle][key]``), each a step of
the model: where a skin vertex lies along the muscle (:math:`\lambda`, :math:`l`) and
across it (:math:`\gamma`), the periodic coordinate :math:`w` and the wrinkle shape
:math:`H(w)`, the attenuation :math:`A_t`, the compression :math:`\varepsilon` and the
response :math:`A(\varepsilon)`, and the muscle's wrinkles :math:`W = H A A_t`. Grey is
*undefined*: outside the muscle's area of influence or its wrinkling region.
"""

import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.plotting import FIELDS, add_skin, set_camera

face = wv.datasets.load_face()
state = face.evaluate("surprise")
muscle = "frontalis_major_L"

# %%
# The nine fields of the left frontalis major, on surprise.
plotter = pv.Plotter(shape=(3, 3), window_size=(1200, 1200), border=False)
for i, (key, info) in enumerate(FIELDS.items()):
    plotter.subplot(i // 3, i % 3)
    add_skin(plotter, state, key, muscle)
    plotter.add_text(f"{key}: {info.name} ({info.equation})", font_size=9)
    set_camera(plotter, "forehead", face)
plotter.show()

# %%
# The total wrinkle amplitude, summed over the muscles (the only field with a total).
state.plot("W", camera="forehead")

# %%
# The same numbers, for your own analysis.
import numpy as np  # noqa: E402

for key in FIELDS:
    values = state.fields[muscle][key]
    print(f"{key:7s} defined at {np.isfinite(values).sum():4d} vertices, "
          f"range [{np.nanmin(values):+8.3f}, {np.nanmax(values):+8.3f}]")
