"""
Adaptive refinement
===================

At the paper's resolution (4,500 triangles) a wrinkle period spans a few edges and the
furrows are faceted. ``refine=True`` splits the triangles where the wrinkled skin bends
(the paper's Fig. 11), puts the new vertices on a smooth surface through the rest skin and
evaluates every field exactly at them.
"""

import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.plotting import add_raking_light, add_skin, set_camera

face = wv.datasets.load_face()
coarse = face.evaluate("surprise")
refined = face.evaluate("surprise", refine=True)
print(f"{coarse.n_points} vertices -> {refined.n_points} after refinement")

# %%
# Side by side under the same raking light: coarse (left) and refined (right).
plotter = pv.Plotter(shape=(1, 2), window_size=(1200, 560), border=False)
for column, (label, state) in enumerate((("coarse", coarse), ("refined", refined))):
    plotter.subplot(0, column)
    add_skin(plotter, state, None)
    add_raking_light(plotter)
    plotter.add_text(f"{label}: {len(state.triangles)} triangles", font_size=10)
    set_camera(plotter, "forehead", face)
plotter.show()

# %%
# The triangles: split where the skin bends, along the furrows, and nowhere else.
refined.plot("W", show_edges=True, camera="forehead")
