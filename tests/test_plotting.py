import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.plotting import (
    CAMERAS,
    FIELDS,
    NAN_COLOR,
    field_info,
    field_range,
    muscle_mesh,
    render_field,
)


def test_catalogue_covers_every_field_with_the_right_kind_of_colour_map():
    assert set(FIELDS) == set(wv.FIELD_NAMES)
    for key in ("lambda", "gamma", "At", "A"):
        assert not FIELDS[key].diverging and FIELDS[key].limits == (0.0, 1.0)
    for key in ("W", "H", "eps"):
        assert FIELDS[key].diverging
    for info in FIELDS.values():
        assert info.equation.startswith("Eq.") and info.meaning and info.title("m").isascii()


def test_field_range_is_centred_for_signed_fields():
    assert field_range(FIELDS["W"], np.array([np.nan, -0.1, 0.3])) == (-0.3, 0.3)
    assert field_range(FIELDS["lambda"], np.array([0.2, 0.5])) == (0.0, 1.0)
    assert field_range(FIELDS["l"], np.array([np.nan, 2.0, 5.0])) == (2.0, 5.0)
    assert field_range(FIELDS["eps"], np.array([np.nan])) == (-1.0, 1.0)
    with pytest.raises(KeyError, match="unknown field 'tau'"):
        field_info("tau")


def test_render_field_returns_an_image_with_nan_drawn_in_the_neutral_colour(wv_face, tmp_path):
    path = tmp_path / "eps.png"
    img = render_field(wv_face, "surprise", "eps", "frontalis_major_L", camera="forehead",
                       size=(300, 300), filename=path)
    assert img.shape == (300, 300, 3) and path.is_file()
    rgb = img.astype(int)
    grey = (rgb.max(axis=2) - rgb.min(axis=2) < 10) & (rgb.max(axis=2) < 235)
    drawn = rgb.min(axis=2) < 235  # not the white background
    # most of the skin is outside this muscle's AOI: shaded grey
    assert grey.sum() > 0.5 * drawn.sum()
    assert pv.Color(NAN_COLOR).int_rgb[0] == pv.Color(NAN_COLOR).int_rgb[2]  # a true grey


def test_render_field_errors(wv_face):
    with pytest.raises(ValueError, match="unknown layer"):
        render_field(wv_face, "surprise", layers=("bones",))
    with pytest.raises(KeyError, match="unknown camera 'top'"):
        render_field(wv_face, "surprise", camera="top")
    with pytest.raises(ValueError, match="belongs to one muscle"):
        render_field(wv_face, "surprise", "eps")
    with pytest.raises(KeyError, match="no muscle 'nope'"):
        render_field(wv_face, "surprise", "eps", "nope")


def test_cameras_all_render(wv_face):
    images = {c: render_field(wv_face, "frown", None, camera=c, size=(120, 120))
              for c in CAMERAS}
    assert len({im.tobytes() for im in images.values()}) == len(CAMERAS)


def test_muscle_meshes_carry_their_activation(wv_face):
    for m in wv_face.muscles:
        mesh = muscle_mesh(m, 0.25)
        assert mesh.n_points > 0 and np.all(mesh["activation"] == 0.25)
    ring = wv.muscle_types()["ring"]("r", (0, 0, 0), (0, 0, 1), radius=10.0)
    assert muscle_mesh(ring).n_points > 0


def test_a_named_camera_looks_the_same_whatever_came_before(wv_face):
    import pyvista as pv

    from wrinkle_vis.plotting import set_camera

    p = pv.Plotter(off_screen=True, window_size=(100, 100))
    try:
        set_camera(p, "front", wv_face)
        fresh = p.camera.view_angle
        set_camera(p, "forehead", wv_face)  # zooms in
        set_camera(p, "front", wv_face)
        assert p.camera.view_angle == pytest.approx(fresh)
    finally:
        p.close()


@pytest.mark.parametrize("size", [(240, 240), (400, 400), (600, 240)])
def test_scalar_bar_title_and_tick_labels_keep_apart(wv_face, size, no_leaked_plotters):
    """The bar's title and its tick labels are separate lines of text, whatever the view's
    size (VTK's fitted fonts squeezed the title onto the labels), with fixed font sizes.
    """
    from wrinkle_vis.plotting import add_skin
    from wrinkle_vis.plotting.bars import BAR_FONT_PX, BAR_TITLE_PX

    plotter = pv.Plotter(off_screen=True, window_size=list(size))
    try:
        plotter.set_background("white")
        add_skin(plotter, wv_face.evaluate("frown"), "gamma", "corrugator_L")
        plotter.camera_position = [(0, 0, -1e4), (0, 0, -2e4), (0, 1, 0)]  # skin unseen
        image = plotter.screenshot(return_img=True).astype(int)
        (bar,) = plotter.scalar_bars.values()
        assert bar.GetUnconstrainedFontSize()
        assert bar.GetLabelTextProperty().GetFontSize() == BAR_FONT_PX
        assert bar.GetTitleTextProperty().GetFontSize() == BAR_TITLE_PX
    finally:
        plotter.close()
    coloured = (image.max(axis=2) - image.min(axis=2)) > 60  # the colour bar (viridis)
    bar_rows = np.flatnonzero(coloured.sum(axis=1) > 0.2 * size[0])
    assert len(bar_rows)
    text = (image.max(axis=2) < 160)[:bar_rows.min()]  # dark text above the colour bar
    rows = text.any(axis=1)
    runs = np.count_nonzero(rows[1:] & ~rows[:-1]) + int(rows[0])
    assert runs >= 2, "the title runs into the tick labels"
