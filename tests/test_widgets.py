"""Placement widgets in off-screen views: the registry look-up, handles that stay on their
surfaces while dragged by (simulated) mouse events, the drawn AOI and wrinkling region.
"""

from dataclasses import dataclass

import numpy as np
import pytest
import pyvista as pv
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.app.models import DisplayOptions
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.views import LinkedViews
from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.plotting import set_camera
from wrinkle_vis.plotting import testing_theme as fixed_theme
from wrinkle_vis.widgets import (
    GenericWidget,
    LinearWidget,
    SheetWidget,
    boundary_lines,
    handles_for,
    register_widget,
    spherical_sector,
    widget_factory,
)
from wrinkle_vis.widgets.placement import _WIDGETS


def showing(session: Session) -> DisplayOptions:
    """What the views show of ``session``: its field of its selected muscle."""
    return DisplayOptions(field=session.field, muscle=session.muscle)


# ---------------------------------------------------------------------- the registry
def test_builtin_types_declare_their_widgets():
    assert widget_factory(wv.LinearMuscle) is LinearWidget
    assert widget_factory(wv.SheetMuscle) is SheetWidget


def test_lookup_follows_the_class_hierarchy_and_falls_back_to_generic():
    @dataclass(frozen=True)
    class Sub(wv.LinearMuscle):  # inherits the linear widget
        pass

    @dataclass(frozen=True)
    class Bare(wv.Muscle):  # declares nothing anywhere
        point_parameters = ("tip", "line")

    assert widget_factory(Sub) is LinearWidget
    assert widget_factory(Bare) is GenericWidget

    class Mine(LinearWidget):
        pass

    register_widget(Sub, Mine)
    try:
        assert widget_factory(Sub) is Mine and widget_factory(wv.LinearMuscle) is LinearWidget
    finally:
        _WIDGETS.pop(Sub)


def test_the_example_plugin_brings_its_own_widget():
    ring = wv.get_muscle_type("ring")
    cls = widget_factory(ring)
    assert cls.__module__ == "wrinkle_vis_ring.widget" and cls.__name__ == "RingWidget"


def test_a_broken_widget_declaration_names_the_type_and_the_fix():
    @dataclass(frozen=True)
    class Broken(wv.LinearMuscle):
        widget = "no_such_package.widgets:Thing"

    with pytest.raises(ImportError, match=r"Broken declares widget = 'no_such_package"):
        widget_factory(Broken)


def test_generic_handles_one_per_point_and_line_end(wv_face):
    sheet = wv_face.muscle("frontalis_inner_L")
    hs = handles_for(sheet)
    assert [(h.param, h.index, h.layer) for h in hs] == [
        ("attachment_line", 0, "skull"), ("attachment_line", 1, "skull"),
        ("insertion_line", 0, "skin"), ("insertion_line", 1, "skin")]
    assert set(hs) == set(SheetWidget.handles(sheet))


# ---------------------------------------------------------------------- drawing helpers
def test_boundary_lines_of_a_square_patch():
    g = grid(6, 6, size=5.0)  # unit cells
    xy = g.points[:, :2]
    mask = (np.abs(xy) <= 1.5 + 1e-9).all(axis=1)  # a 3 x 3 cell square
    lines = boundary_lines(g, mask)
    assert lines.n_lines == 12  # its perimeter, one unit edge each
    assert np.allclose(np.abs(lines.points[:, :2]).max(axis=1), 1.5)
    assert boundary_lines(g, np.zeros(g.n_points, bool)).n_points == 0
    lifted = boundary_lines(g, mask, g.points + (0.0, 0.0, 2.0))  # drawn elsewhere
    assert lifted.n_lines == 12 and np.allclose(lifted.points[:, 2], g.points[0, 2] + 2.0)


def test_spherical_sector_is_the_linear_aoi():
    apex, axis = np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 2.0])
    sector = spherical_sector(apex, axis, radius=10.0, half_angle_deg=30.0)
    v = sector.points[1:] - apex
    assert np.allclose(np.linalg.norm(v, axis=1), 10.0)
    angles = np.degrees(np.arccos(v[:, 2] / 10.0))
    assert angles.max() == pytest.approx(30.0) and angles.min() == pytest.approx(0.0)


# ---------------------------------------------------------------------- dragging
@pytest.fixture
def views(wv_face):
    """Off-screen linked views of the built-in face on surprise, frontalis selected."""
    theme = fixed_theme()
    plotters = [pv.Plotter(off_screen=True, theme=theme) for _ in range(3)]
    for p in plotters[1:]:
        p.renderer.camera = plotters[0].renderer.camera
    for p in plotters:
        p.show(auto_close=False, interactive=False)  # interactors before widgets
    v = LinkedViews(*plotters)
    yield v
    v.close_placement()
    for p in plotters:
        p.close()


def _display(plotter, point):
    r = plotter.renderer
    r.SetWorldPoint(*point, 1.0)
    r.WorldToDisplay()
    return np.array(r.GetDisplayPoint()[:2])


def drag(plotter, start, end, steps: int = 5):
    """Press at display ``start``, move in ``steps`` to ``end``, release: as a mouse."""
    iren = plotter.iren.interactor

    def event(name, xy):
        iren.SetEventInformation(int(round(xy[0])), int(round(xy[1])))
        iren.InvokeEvent(name)

    event("MouseMoveEvent", start)
    event("LeftButtonPressEvent", start)
    for t in np.linspace(0, 1, steps + 1)[1:]:
        event("MouseMoveEvent", start + t * (np.asarray(end) - start))
    event("LeftButtonReleaseEvent", end)


def _select(views, session, name, camera="front"):
    session.set_field("W", name)
    views.draw(session.state(), showing(session), session.face)
    set_camera(views.skin_view, camera, session.face)
    views.render()
    return views.placement


@pytest.mark.parametrize(("name", "layer"), [("zygomaticus_major_L", "skin"),
                                             ("zygomaticus_major_L", "skull"),
                                             ("frontalis_major_L", "skin")])
def test_a_dragged_handle_stays_on_its_surface_and_moves_the_muscle(wv_face, views, name,
                                                                    layer):
    session = Session(wv_face)
    session.set_expression("smile" if "zygomaticus" in name else "surprise")  # it is active
    moves = []

    def on_move(handle, point, finished):
        moves.append((handle, point, finished))
        session.set_face(session.face.with_muscle(wv.core.editing.with_point(
            session.face.muscle(name), handle.param, handle.index, point)))
        views.draw(session.state(), showing(session), session.face)

    views.on_move = on_move
    widget = _select(views, session, name, "forehead" if "frontalis" in name else "front")
    handle = next(h for h in widget.handles(widget.muscle) if h.layer == layer)
    plotter = widget.views[layer]
    before = session.face.muscle(name)
    w_before = session.state().W.copy()
    start = _display(plotter, widget.position(handle))
    drag(plotter, start, start + (-14, 9))  # towards the middle of the face
    assert moves and moves[-1][2] and not any(f for _, _, f in moves[:-1])
    after = session.face.muscle(name)
    assert not np.allclose(handle.value(after), handle.value(before))  # the point moved
    assert np.allclose(handle.value(after), moves[-1][1])
    surface = wv_face.skin if layer == "skin" else wv_face.skull
    p = handle.value(after)  # a rest position on its surface
    assert np.linalg.norm(closest_points(surface, p[None])[0] - p) < 1e-6
    drawn = widget.position(handle)  # the handle is drawn on the surface as shown
    shown = session.state().face.skin.with_points(session.state().points) \
        if layer == "skin" else surface
    assert np.linalg.norm(closest_points(shown, drawn[None])[0] - drawn) < 1e-6
    if layer == "skin":
        assert not np.array_equal(session.state().W, w_before)  # the fields follow


def test_the_selected_muscles_aoi_and_region_are_drawn(wv_face, views):
    session = Session(wv_face)
    _select(views, session, "frontalis_major_L")
    names = set(views.muscle_view.actors)
    assert {"widget:aoi", "widget:region", "widget:aoi_volume", "widget:aoi_rectangle"} <= names
    assert {"widget:aoi", "widget:region"} <= set(views.skin_view.actors)
    region = views.skin_view.actors["widget:region"].mapper.dataset
    data = wv_face.muscle_data(wv_face.muscle("frontalis_major_L"))
    assert region.n_lines > 10
    state = session.state()
    shown = wv_face.skin.with_points(state.points)  # the skin as drawn (deformed)
    near = closest_points(shown, region.points)  # lifted 0.4 mm off it
    assert np.linalg.norm(near - region.points, axis=1).max() < 0.5
    # the outline runs along the region's own vertices
    ids = shown.kdtree.query(near)[1]
    assert np.isin(ids, data.region).mean() > 0.5
    _select(views, session, "zygomaticus_major_L")
    assert "widget:aoi_rectangle" not in views.muscle_view.actors  # the sheet's is gone
    session.set_field("W", None)
    views.draw(session.state(), showing(session), session.face)
    assert views.placement is None
    assert not any(n.startswith("widget:") for n in views.muscle_view.actors)


def _outline_as_rebuilt(state, muscle, kind):
    """The outline a frame drew before issue 28: found anew on the frame's skin."""
    data = state.face.muscle_data(muscle)
    mask = np.zeros(state.n_points, bool)
    mask[data.aoi if kind == "aoi" else data.region] = True
    return boundary_lines(state.face.skin, mask, state.points + 0.4 * state.normals)


def test_the_outlines_are_found_once_per_muscle_and_moved_with_the_skin(wv_face, views):
    """Issue 28: the AOI and region outlines and the AOI volumes depend on the rest skin
    and the muscle alone; a new frame moves the same meshes (exactly where a rebuild would
    draw them), an edit of the muscle finds them again."""
    session = Session(wv_face)
    _select(views, session, "frontalis_major_L")
    drawn = {k: views.skin_view.actors[f"widget:{k}"].mapper.dataset for k in ("aoi", "region")}
    volume = views.muscle_view.actors["widget:aoi_volume"].mapper.dataset
    before = np.array(drawn["region"].points)
    for intensity in (0.5, 0.8):
        session.set_intensity(intensity)
        views.draw(session.state(), showing(session), session.face)
        muscle = session.face.muscle("frontalis_major_L")
        for kind, mesh in drawn.items():
            for view in (views.skin_view, views.muscle_view):
                assert view.actors[f"widget:{kind}"].mapper.dataset is mesh  # not rebuilt
            want = _outline_as_rebuilt(session.state(), muscle, kind)
            assert np.array_equal(mesh.points, want.points)
            assert np.array_equal(mesh.lines, want.lines)
        assert views.muscle_view.actors["widget:aoi_volume"].mapper.dataset is volume
    assert not np.array_equal(drawn["region"].points, before)  # it moved with the skin
    # an edit: a narrower sheet has another AOI, region and box
    muscle = session.face.muscle("frontalis_major_L")
    session.set_face(session.with_parameter(muscle.name, "width", 0.6 * muscle.width_value))
    views.draw(session.state(), showing(session), session.face)
    muscle = session.face.muscle("frontalis_major_L")
    for kind in ("aoi", "region"):
        mesh = views.skin_view.actors[f"widget:{kind}"].mapper.dataset
        want = _outline_as_rebuilt(session.state(), muscle, kind)
        assert mesh.n_points != drawn[kind].n_points
        assert np.array_equal(mesh.points, want.points)
        assert np.array_equal(mesh.lines, want.lines)
    edited = views.muscle_view.actors["widget:aoi_volume"].mapper.dataset
    assert edited is not volume and not np.allclose(edited.bounds, volume.bounds)


@pytest.mark.parametrize("name", ["zygomaticus_major_L", "frontalis_major_L"])
def test_placement_widget_image(wv_face, views, verify_image_cache, name):
    session = Session(wv_face)
    _select(views, session, name, camera="three_quarter")
    verify_image_cache(views.muscle_view)  # against tests/image_cache (looked at)


def test_the_generic_widget_places_a_type_without_its_own(wv_face, views):
    ring_type = wv.get_muscle_type("ring")

    @dataclass(frozen=True)
    class PlainRing(ring_type):  # declares the generic widget over the ring's own
        widget = "wrinkle_vis.widgets.placement:GenericWidget"

    at = wv_face.skin.points[np.argmax(wv_face.skin.points[:, 2])]  # the nose tip
    ring = PlainRing("ring_plain", tuple(at), (0.0, 0.0, 1.0), radius=15.0)
    face = wv_face.with_muscle(ring)
    session = Session(face)
    session.set_activation("ring_plain", 1.0)
    moved = []
    views.on_move = lambda h, p, f: moved.append((h, p, f))
    widget = _select(views, session, "ring_plain")
    assert type(widget) is GenericWidget
    assert [(h.param, h.layer) for h in widget.handles(ring)] == [("center", "skin")]
    assert {"widget:aoi", "widget:region"} <= set(views.skin_view.actors)
    handle = widget.handles(ring)[0]
    start = _display(views.skin_view, widget.position(handle))
    drag(views.skin_view, start, start + (8, 8))
    assert moved and moved[-1][2]
    p = moved[-1][1]
    assert np.linalg.norm(p - at) > 1.0
    assert np.linalg.norm(closest_points(wv_face.skin, p[None])[0] - p) < 1e-6


def test_a_face_without_skull_puts_skull_handles_on_the_skin(wv_face, views):
    face = wv.FaceModel(wv_face.skin, None, wv_face.muscles, wv_face.expressions)
    session = Session(face)
    widget = _select(views, session, "zygomaticus_major_L")
    handle = next(h for h in widget.handles(widget.muscle) if h.layer == "skull")
    assert widget.views["skull"] is views.skin_view
    assert "skull" not in views.skull_view.actors
    assert widget.widgets[handle].GetEnabled()
