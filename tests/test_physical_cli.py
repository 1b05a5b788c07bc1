"""``--skin-model physical`` on the commands, and ``figure fig10``."""

import dataclasses

import imageio.v3 as iio
import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.cli import main


def test_summary_and_export_use_the_physical_skin(tmp_path, capsys):
    assert main(["summary", "-e", "frown", "--skin-model", "physical"]) == 0
    out = capsys.readouterr().out
    assert "== frown (intensity 1, physical skin," in out
    path = tmp_path / "frown.vtp"
    assert main(["export", "-e", "frown", "--skin-model", "physical", "-o", str(path)]) == 0
    mesh = pv.read(path)
    still = wv.datasets.load_face().evaluate("frown", skin="physical")
    np.testing.assert_allclose(mesh.points, still.points, atol=1e-5)


def test_figure_fig10_shows_the_wrinkles_forming(tmp_path, capsys):
    out = tmp_path / "fig10.png"
    assert main(["figure", "fig10", "--times", "0.033", "0.3", "--size", "320", "160",
                 "-o", str(out)]) == 0
    image = iio.imread(out)
    assert image.shape[:2] == (160, 320)
    left, right = image[:, :160].astype(float), image[:, 160:].astype(float)
    assert np.abs(left - right).mean() > 0.5  # the panels differ: the wrinkles grew


def test_times_belong_to_fig10(tmp_path, capsys):
    assert main(["figure", "fig9", "--times", "0.1", "-o", str(tmp_path / "a.png")]) == 2
    assert "--times is for fig10" in capsys.readouterr().err


def test_an_expressions_timeline_is_simulated_on_the_physical_skin():
    face = wv.datasets.load_face().with_skin_model("geometric")  # each frame on its own
    expression = face.expressions["frown"]
    times = [0.0, 0.1, 0.2, 0.4]
    geo = list(face.expression_states(expression, times))
    for t, state in zip(times, geo, strict=True):
        np.testing.assert_array_equal(state.points, face.evaluate(expression.at(t)).points)
    phys = list(face.with_skin_model("physical").expression_states(expression, times))
    assert [s.time for s in phys] == pytest.approx(times)
    assert all(s.skin_model == "physical" for s in phys)
    # the skin lags behind the command (activation dynamics), then catches up
    w = [np.abs(s.W).sum() for s in phys]
    assert w[0] == 0.0 and w[1] < w[2] <= w[3] * 1.1


def test_export_sequence_on_the_physical_skin(tmp_path):
    out = tmp_path / "frown.pvd"
    assert main(["export", "--sequence", "--fps", "2", "-e", "frown", "--skin-model",
                 "physical", "-o", str(out)]) == 0
    frames = sorted((tmp_path / "frown").rglob("*.vtp"))  # in the index's version folder
    assert len(frames) >= 2


def test_a_layouts_skin_model_holds_unless_the_command_line_says_otherwise(tmp_path, capsys):
    from wrinkle_vis.core.layout import load_layout, save_layout
    from wrinkle_vis.datasets.face import BUILTIN_LAYOUT

    path = tmp_path / "phys.json"
    save_layout(dataclasses.replace(load_layout(BUILTIN_LAYOUT), skin_model="physical"), path)
    assert main(["summary", "-e", "frown", "--layout", str(path)]) == 0
    assert "physical skin" in capsys.readouterr().out
    assert main(["summary", "-e", "frown", "--layout", str(path), "--skin-model",
                 "geometric"]) == 0
    assert "physical skin" not in capsys.readouterr().out
