r"""
A parameter sweep, read with pandas
===================================

A sweep evaluates the face once per combination of parameters and records every parameter
and every metric in one Parquet table (``docs/sweeps.md``). Here the six frontalis (the
face's sheet muscles) get :math:`n_w` = 2, 3 or 4 wrinkles and a furrow depth factor
:math:`k_0` of 1 or 3 mm, surprise is evaluated with adaptive refinement, and the table
answers two questions: does the skin show the :math:`n_w` crests the model puts along each
fibre (Eq. 6, 7), and how deep are the furrows against :math:`k_0`?

Six runs on two local worker processes. Run again, the sweep finds its runs finished and
only reads the table (the next example uses the same folder).
"""

import tempfile
from pathlib import Path

import pandas as pd
import pyvista as pv

import wrinkle_vis as wv
import wrinkle_vis.plotting  # noqa: F401 (off screen through EGL where there is no display)

SPEC = {
    "name": "gallery",
    "faces": [{"name": "procedural", "n_triangles": 4500}],
    "expressions": ["surprise"],
    "refine": [True],
    "vary": [
        {"type": "sheet", "parameter": "n_wrinkles", "values": [2, 3, 4]},
        {"type": "sheet", "parameter": "k0", "values": [1.0, 3.0]},
    ],
    "outputs": {"images": {"fields": ["none", "W"], "cameras": ["forehead"],
                           "size": [300, 300], "raking_light": True}},
}
OUT = Path(tempfile.gettempdir()) / "wrinkle-vis-gallery-sweep"

# %%
# Local workers are spawned processes that import this script again: a script that starts
# them runs the sweep under ``if __name__ == "__main__"`` (sphinx-gallery runs the examples
# as ``__main__``).
if __name__ == "__main__":
    table = wv.sweep(SPEC, OUT, workers=2, progress=False)
    columns = ["type:sheet.n_wrinkles", "type:sheet.k0", "crests", "n_w", "crests_match",
               "furrow_depth_median", "W_range", "status"]
    print(table[columns].to_string(index=False))

# %%
# The crests counted along the six fibres against the :math:`n_w` the model puts there (the
# line of equality in grey): two and three are found, of four the cuts find three. And the
# median furrow depth against :math:`k_0`: in proportion, for every :math:`n_w`.
if __name__ == "__main__":
    table = pd.read_parquet(OUT / "results.parquet")
    per = table.assign(n_w_each=table["type:sheet.n_wrinkles"], crests_each=table["crests"] / 6)
    left = pv.Chart2D(x_label="n_w of each frontalis", y_label="crests per fibre (mean)")
    left.line([1.5, 4.5], [1.5, 4.5], color="lightgrey", width=2)
    right = pv.Chart2D(x_label="k0 (mm)", y_label="median furrow depth (mm)")
    colours = {1.0: "tab:blue", 3.0: "tab:orange"}
    for k0, group in per.groupby("type:sheet.k0"):
        group = group.sort_values("n_w_each")
        left.scatter(group["n_w_each"], group["crests_each"], color=colours[k0], size=12,
                     label=f"k0 = {k0:g}")
    for (n_w, group), colour in zip(per.groupby("n_w_each"),
                                    ("tab:green", "tab:purple", "tab:red"), strict=True):
        group = group.sort_values("type:sheet.k0")
        right.line(group["type:sheet.k0"], group["furrow_depth_median"], width=3,
                   color=colour, label=f"n_w = {n_w}")
    plotter = pv.Plotter(shape=(1, 2), window_size=(1000, 420))
    plotter.subplot(0, 0)
    plotter.add_chart(left)
    plotter.subplot(0, 1)
    plotter.add_chart(right)
    plotter.show()
