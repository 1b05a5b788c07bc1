"""``--skin-model physical`` on the commands, and ``figure fig10``."""

import imageio.v3 as iio
import numpy as np
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
