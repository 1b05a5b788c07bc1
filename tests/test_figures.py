"""The paper's figures (``wrinkle-vis figure``) and the raking light, off screen."""

import imageio.v3 as iio
import numpy as np
import pytest
import pyvista as pv

from wrinkle_vis.cli import main
from wrinkle_vis.plotting import add_raking_light
from wrinkle_vis.plotting.figures import EDGE_COLOR

PANEL = 300  # pixels: small and fast
TITLE = 36  # rows of a panel that hold its title


def _gray(path) -> np.ndarray:
    return iio.imread(path)[..., :3].astype(float).mean(axis=2)


def _panels(gray: np.ndarray, rows: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each row's (without, with) panels."""
    assert gray.shape == (rows * PANEL, 2 * PANEL)
    return [(gray[r * PANEL:(r + 1) * PANEL, :PANEL], gray[r * PANEL:(r + 1) * PANEL, PANEL:])
            for r in range(rows)]


def _is_a_face_panel(panel: np.ndarray) -> bool:
    """Skin in the middle, white background at both sides: one panel, not blank."""
    skin = panel < 245
    middle = panel[TITLE:, PANEL // 3:2 * PANEL // 3]
    return 0.4 < skin.mean() < 0.95 and (middle < 245).all() and \
        (panel[TITLE:-TITLE, :6] > 250).all() and (panel[TITLE:-TITLE, -6:] > 250).all()


def test_fig9_shows_each_expression_without_and_with_wrinkles(tmp_path, capsys):
    out = tmp_path / "fig9.png"
    assert main(["figure", "fig9", "--refine", "--size", str(2 * PANEL), str(3 * PANEL),
                 "-o", str(out)]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {out}"
    for without, with_ in _panels(_gray(out), 3):  # surprise, frown, fear
        assert _is_a_face_panel(without) and _is_a_face_panel(with_)
        diff = np.abs(with_ - without)[TITLE:]
        changed = np.flatnonzero(diff.max(axis=1) > 10) + TITLE
        assert changed.size > 5, "the wrinkles do not show"
        # the camera frames the wrinkles (forehead to brows here): none at the bottom edge
        assert changed.max() < PANEL - 10, "wrinkles cut off at the bottom"
    surprise = _panels(_gray(out), 3)[0]
    band = np.abs(surprise[1] - surprise[0])[TITLE:PANEL // 2]  # the forehead furrows
    assert (band > 10).mean() > 0.01


def test_fig9_rows_follow_the_expressions(tmp_path):
    out = tmp_path / "two.png"
    assert main(["figure", "fig9", "-e", "fear", "-e", "surprise", "--size", str(2 * PANEL),
                 str(2 * PANEL), "-o", str(out)]) == 0
    (fear_0, fear_1), (surprise_0, surprise_1) = _panels(_gray(out), 2)
    assert all(_is_a_face_panel(p) for p in (fear_0, fear_1, surprise_0, surprise_1))
    assert np.abs(fear_1 - fear_0)[TITLE:].max() > 10
    assert np.abs(surprise_1 - fear_1)[TITLE:].max() > 10  # two different expressions


def test_fig11_draws_the_refined_mesh_over_the_forehead(tmp_path):
    out = tmp_path / "fig11.png"
    assert main(["figure", "fig11", "--size", str(PANEL), str(PANEL), "-o", str(out)]) == 0
    image = iio.imread(out)[..., :3].astype(float)
    assert image.shape == (PANEL, PANEL, 3)
    skin = image.mean(axis=2) < 245
    assert 0.4 < skin.mean() < 0.95
    # white light keeps the skin's blue/red ratio (0.68) whatever the shading; the edges'
    # colour (0.45) lowers it
    assert int(EDGE_COLOR[5:7], 16) / int(EDGE_COLOR[1:3], 16) < 0.5
    edges = skin & (image[..., 2] / np.maximum(image[..., 0], 1.0) < 0.62)
    assert edges.sum() > 0.1 * skin.sum()
    forehead = edges[int(0.35 * PANEL):int(0.65 * PANEL)].mean()
    crown = edges[int(0.12 * PANEL):int(0.25 * PANEL)].mean()
    assert forehead > 1.5 * crown  # refined where the furrows bend the skin


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["figure", "fig9", "-o", "x.jpg"], "--output must end in .png"),
        (["figure", "fig9", "-e", "laughing", "-o", "x.png"], "unknown expression 'laughing'"),
        (["figure", "fig11", "-e", "fear", "-e", "frown", "-o", "x.png"],
         "fig11 shows one expression"),
        (["figure", "fig9", "--size", "8", "300", "-o", "x.png"], "too small"),
    ],
)
def test_bad_figure_arguments_are_one_line_errors(argv, message, capsys, tmp_path,
                                                  monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and err.startswith("wrinkle-vis figure: ")
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["figure", "fig12", "-o", "x.png"], "invalid choice: 'fig12'"),
        (["figure", "fig9"], "required: --output"),
        (["figure", "fig9", "-o", "x.png", "--intensity", "-1"], "outside [0, 1]"),
    ],
)
def test_figure_parser_errors(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2 and message in capsys.readouterr().err


def test_help_lists_figure(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "figure" in capsys.readouterr().out


def test_raking_light_replaces_the_active_renderers_lights():
    plotter = pv.Plotter(off_screen=True, shape=(1, 2))
    try:
        plotter.subplot(0, 1)
        key, fill = add_raking_light(plotter, elevation_deg=30.0, azimuth_deg=90.0,
                                     fill=0.2)
        assert list(plotter.renderers[1].lights) == [key, fill]
        assert len(plotter.renderers[0].lights) == 5  # the other subplot keeps its kit
        assert key.is_scene_light and not key.positional and fill.is_headlight
        assert fill.intensity == 0.2
        towards = np.subtract(key.position, key.focal_point)
        np.testing.assert_allclose(towards / np.linalg.norm(towards),
                                   [np.cos(np.pi / 6), 0.0, 0.5], atol=1e-12)
    finally:
        plotter.close()


def _outside_view(points, camera_position, aspect, view_angle_deg=30.0) -> int:
    """How many ``points`` a perspective camera leaves out of its view."""
    eye, focus, up = (np.asarray(v, float) for v in camera_position)
    d = (focus - eye) / np.linalg.norm(focus - eye)
    up = up - (up @ d) * d
    up /= np.linalg.norm(up)
    right = np.cross(d, up)
    rel = points - eye
    depth = rel @ d
    t = np.tan(np.radians(view_angle_deg / 2))
    return int(((np.abs(rel @ up) > depth * t) | (np.abs(rel @ right) > depth * t * aspect)
                | (depth <= 0)).sum())


@pytest.mark.parametrize("expressions", [["smile"], ["pucker"], ["surprise", "smile"],
                                         ["surprise", "frown", "fear"]])
def test_fig9_camera_sees_every_wrinkle(wv_face, expressions):
    """fig9 frames the wrinkles of its expressions, whichever muscles made them: the
    mouth's as well as the forehead's (the upper_face camera cut the mouth's off).
    """
    from wrinkle_vis.plotting.figures import wrinkle_camera

    states = [wv_face.evaluate(e) for e in expressions]
    wrinkled = np.vstack([s.points[s.W != 0] for s in states])
    aspect = 440 / 400
    camera = wrinkle_camera(states, aspect)
    assert _outside_view(wrinkled, camera, aspect) == 0
    # and it is no wider than it needs: the wrinkles fill a good part of the view
    eye, focus, _ = (np.asarray(v) for v in camera)
    half = np.linalg.norm(focus - eye) * np.tan(np.radians(15))
    extent = np.ptp(wrinkled[:, 1])
    assert extent > 0.5 * half or extent < 0.1 * np.ptp(wv_face.skin.points[:, 1])
    if expressions == ["smile"]:  # what the fixed camera did
        plotter = pv.Plotter(off_screen=True, window_size=[440, 400])
        try:
            from wrinkle_vis.plotting import set_camera

            set_camera(plotter, "upper_face", wv_face)
            assert _outside_view(wrinkled, plotter.camera_position, aspect) > 0
        finally:
            plotter.close()
    assert wrinkle_camera([wv_face.evaluate("neutral")]) is None
