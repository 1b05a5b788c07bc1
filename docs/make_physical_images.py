"""Render the physically based skin's figures of docs/model.md (no Qt; off-screen).

Usage:  .venv/bin/python docs/make_physical_images.py

Writes ``images/fig9_geometric.png`` (Fig. 9 on the geometric skin, refined as the paper
renders it, to hold beside ``images/fig9.png``, the default physical skin's; the same as
``wrinkle-vis figure fig9 --refine --skin-model geometric``),
``images/fig10.png`` (wrinkles forming after a step to surprise),
``images/physical_maps.png`` (W and the compression of one muscle, geometric and physical
skin side by side, for surprise, frown and fear) and ``images/physical_step.png`` (W
against time after a step), and prints the step response's numbers.
"""

from pathlib import Path

import numpy as np
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.plotting import add_skin, set_camera
from wrinkle_vis.plotting.figures import figure_dynamics, figure_expressions
from wrinkle_vis.plotting.writers import save_image

OUT = Path(__file__).with_name("images")
#: Whose compression each row shows.
MUSCLE = {"surprise": "frontalis_major_R", "frown": "corrugator_R", "fear": "frontalis_inner_R"}


def maps(face, size=(300, 260)) -> np.ndarray:
    """``(h, w, 3)``: rows surprise, frown, fear; columns W and eps, geometric then
    physical.
    """
    rows = list(MUSCLE)
    plotter = pv.Plotter(off_screen=True, shape=(len(rows), 4), border=False,
                         window_size=[4 * size[0], len(rows) * size[1]])
    try:
        plotter.set_background("white")
        for r, name in enumerate(rows):
            states = {s: face.evaluate(name, skin=s) for s in ("geometric", "physical")}
            for c, (field, skin) in enumerate((("W", "geometric"), ("W", "physical"),
                                               ("eps", "geometric"), ("eps", "physical"))):
                plotter.subplot(r, c)
                muscle = None if field == "W" else MUSCLE[name]
                add_skin(plotter, states[skin], field, muscle, scalar_bar=False)
                label = f"{name}: {field}" + (f" {muscle}" if muscle else "") + f", {skin}"
                plotter.add_text(label, position="upper_edge", font_size=7, color="black")
                set_camera(plotter, "upper_face", face)
        return plotter.screenshot(None, return_img=True)
    finally:
        plotter.close()


def step_response(face, dt=0.005, duration=0.5):
    """Times and the total |W| (normalised by the last) after a step to surprise."""
    states = list(face.simulate("surprise", duration, dt))
    t = np.array([s.time for s in states])
    w = np.array([np.abs(s.W).sum() for s in states])
    return t, w / w[-1]


def main() -> None:
    """Write the four images and print the step response."""
    face = wv.datasets.load_face()
    save_image(figure_expressions(face.with_skin_model("geometric"), refine=True),
               OUT / "fig9_geometric.png")
    save_image(figure_dynamics(face, "surprise"), OUT / "fig10.png")
    save_image(maps(face), OUT / "physical_maps.png")
    t, w = step_response(face)
    t30, w30 = step_response(face, 1.0 / 30.0)
    print("t (ms)  W / W(0.5 s), dt 5 ms")
    for k in range(0, len(t), 4):
        print(f"{1e3 * t[k]:6.0f}  {w[k]:.3f}")
    print(f"90 % at {1e3 * t[np.argmax(w >= 0.9)]:.0f} ms; peak {w.max():.3f}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3), dpi=120)
    ax.plot(1e3 * t, w, label="h = 5 ms")
    ax.plot(1e3 * t30, w30, "o", ms=3, label="h = 1/30 s")
    ax.axhline(0.9, color="grey", lw=0.5)
    ax.set_xlabel("time after the step to surprise (ms)")
    ax.set_ylabel("sum |W| / final")
    ax.legend()
    fig.tight_layout()
    fig.savefig(OUT / "physical_step.png")


if __name__ == "__main__":
    main()
