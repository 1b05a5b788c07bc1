"""The app's split (issue 28): Qt-free models with events, controls bound both ways, one
frame per event-loop turn, and a plug-in muscle type's own parameter panel.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.app.models import Display, DisplayOptions, Document, Playback, Signal
from wrinkle_vis.app.session import Session

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")


def test_the_models_import_no_qt():
    code = ("import sys, wrinkle_vis.app.models; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('qtpy', 'PySide6', 'PyQt5', 'PyQt6', 'PySide2')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"


def test_a_signal_holds_a_listeners_object_weakly():
    heard = []

    class Listener:
        def hear(self, what):
            heard.append(what)

    signal, listener = Signal(), Listener()
    signal.connect(listener.hear)
    signal.emit("a")
    del listener
    signal.emit("b")
    assert heard == ["a"]


def test_the_models_emit_what_changed_and_only_that():
    display, heard = Display(), []
    display.changed.connect(heard.append)
    display.set(plain=True, wireframe=False)  # wireframe was off already
    assert heard == ["plain"] and display.options == DisplayOptions(plain=True)
    with pytest.raises(dataclasses_error()):
        display.options.plain = False  # the views get an immutable snapshot
    playback, heard = Playback(), []
    playback.changed.connect(heard.append)
    playback.playing = True
    playback.playing = True
    playback.start = (3, 1.0)  # not an event: only where Play started
    assert heard == ["playing"]


def dataclasses_error():
    import dataclasses

    return dataclasses.FrozenInstanceError


def test_the_document_is_the_one_owner_of_dirty(wv_face):
    doc, heard = Document(Session(wv_face)), []
    doc.changed.connect(heard.append)
    doc.set_dirty(True)
    doc.set_dirty(True)
    assert doc.session.dirty and heard == ["dirty"]
    doc.replace(Session(wv_face), modified=False)
    assert heard == ["dirty", "session"] and not doc.session.dirty
    doc.replace(Session(wv_face), modified=True)  # a mesh chosen, work restored
    assert heard[-2:] == ["session", "dirty"] and doc.session.dirty


def test_a_bound_control_shows_the_model_without_echoing_it(make_window):
    w = make_window()
    edits = []
    w.document.changed.connect(edits.append)
    w.document.set_intensity(0.25)  # the model changes: the slider shows it, silently
    w.document.changed.emit("session")
    assert w.intensity_slider.value() == 25
    assert edits == ["frame", "session"]  # no echo from the slider
    w.intensity_slider.setValue(60)  # the control changes: the model follows
    assert w.session.intensity == 0.6
    w.display.set(plain=True)
    assert w.field_box.currentText() == "none" and w.active_array() is None


def test_changes_in_one_turn_draw_one_frame(make_window, qtbot):
    w = make_window()
    qtbot.wait(10)
    drawn = []
    w.views.draw = _counting(w.views.draw, drawn)
    w.intensity_slider.setValue(50)
    w.time_slider.setValue(100)
    w.muscle_box.setCurrentText("corrugator_L")
    w.wireframe_box.setChecked(True)
    assert drawn == []  # nothing drawn by hand
    qtbot.waitUntil(lambda: len(drawn) > 0, timeout=2000)
    qtbot.wait(50)
    assert len(drawn) == 1
    w.frames.flush()  # nothing pending: nothing drawn
    assert len(drawn) == 1


def _counting(method, calls):
    def counted(*args, **kwargs):
        calls.append(args)
        return method(*args, **kwargs)
    return counted


def test_a_plugin_type_brings_its_own_parameter_panel(make_window, wv_face):
    from wrinkle_vis.app.parameters import _LOOKUP, ParameterPanel, panel_factory, register_panel

    ring_type = wv.get_muscle_type("ring")

    class RingPanel(ParameterPanel):
        """The default panel and a note of the plug-in's own."""

        def __init__(self, muscle, unit, edits):
            super().__init__(muscle, unit, edits)
            self.note = self.form.addRow("ring", type(self.error)("a ring's own panel"))

    assert panel_factory(ring_type) is ParameterPanel  # the default: from the metadata
    register_panel(ring_type, RingPanel)
    try:
        ring = ring_type.create("orbicularis_ring", (35.0, 0.0, 100.0), wv_face.skin,
                                wv_face.skull)
        w = make_window(Session(wv_face.with_muscle(ring)))
        w.select_muscle("orbicularis_ring")
        assert type(w.parameters.panel) is RingPanel
        assert w.set_parameter("radius", 18.0)  # its boxes still edit, undoably
        assert w.session.face.muscle("orbicularis_ring").radius == 18.0
        w.select_muscle("corrugator_L")  # another type: the default panel
        assert type(w.parameters.panel) is ParameterPanel
    finally:
        _LOOKUP.registered.pop(ring_type, None)


def test_the_views_draw_a_frame_as_the_options_say_with_no_session(wv_face):
    """LinkedViews.draw takes the frame, a frozen DisplayOptions (field, muscle, colour map
    and range, switches) and the face: no session; a new colour map rebuilds the scene."""
    import inspect

    import pyvista as pv
    from matplotlib import colormaps

    from wrinkle_vis.app.views import LinkedViews
    from wrinkle_vis.plotting.polydata import field_array_name

    assert "session" not in inspect.signature(LinkedViews.draw).parameters
    plotters = [pv.Plotter(off_screen=True, window_size=(200, 160)) for _ in range(3)]
    try:
        views = LinkedViews(*plotters)
        state = wv_face.evaluate("frown")
        options = DisplayOptions(field="eps", muscle="corrugator_L", cmap="magma",
                                 clim=(-0.1, 0.2), raking_light=True)
        assert views.draw(state, options, wv_face)
        mapper = plotters[0].actors["skin"].mapper
        assert tuple(mapper.scalar_range) == (-0.1, 0.2)
        assert mapper.dataset.active_scalars_name == field_array_name("eps", "corrugator_L")
        table = mapper.lookup_table
        assert np.allclose(table.GetTableValue(0)[:3], colormaps["magma"](0.0)[:3], atol=0.01)
        assert views.placement.muscle.name == "corrugator_L" and views.raking_light
        same = dataclasses.replace(options, clim=(-0.2, 0.3))
        assert not views.draw(wv_face.evaluate("fear"), same, wv_face)  # in place
        assert tuple(mapper.scalar_range) == (-0.2, 0.3)
        assert views.draw(state, dataclasses.replace(same, cmap=None), wv_face)  # rebuilt
        table = plotters[0].actors["skin"].mapper.lookup_table
        assert np.allclose(table.GetTableValue(0)[:3], colormaps["PuOr_r"](0.0)[:3],
                           atol=0.01)  # eps's own map
        with pytest.raises(ValueError, match="min must be below max"):
            DisplayOptions(clim=(1.0, 1.0))
    finally:
        views.close_placement()
        for p in plotters:
            p.close()


def test_the_display_owns_the_colour_map_range_and_camera(make_window, wv_face):
    """The colour map box, the range controls and the View menu's cameras are bound to
    the Display model: a control sets it, a change of it shows in the controls (no echo),
    and a new face keeps them (shown from the camera chosen)."""
    from wrinkle_vis.plotting import set_camera

    w = make_window()
    heard = []
    w.display.changed.connect(heard.append)
    w.cmap_box.setCurrentText("magma")
    assert w.display.options.cmap == "magma" and heard == ["cmap"]
    w.display.set(cmap=None)
    assert w.cmap_box.currentText() == "field's own"
    w.display.set(clim=(-0.5, 0.25))
    assert w.range_box.currentText() == "fixed" and w.range_min.isEnabled()
    assert (w.range_min.value(), w.range_max.value()) == (-0.5, 0.25)
    assert tuple(w.skin_view.actors["skin"].mapper.scalar_range) == (-0.5, 0.25)
    w.set_camera("forehead")
    assert w.display.options.camera == "forehead" and heard[-1] == "camera"
    w.document.replace(Session(wv_face))  # a new face: the display's choices stay
    position = w.skin_view.camera_position
    assert w.range_box.currentText() == "fixed"
    assert tuple(w.skin_view.actors["skin"].mapper.scalar_range) == (-0.5, 0.25)
    set_camera(w.skin_view, "front", wv_face)
    assert w.skin_view.camera_position != position  # it was the forehead's
    set_camera(w.skin_view, "forehead", wv_face)
    assert w.skin_view.camera_position == position
    w.range_box.setCurrentText("automatic")
    assert w.display.options.clim is None and not w.range_min.isEnabled()


def test_the_views_multisample_only_when_the_display_says(make_window):
    """PyVista's theme turns multisampling on (about 2.5x the render in software); the
    views follow the display's option from the first frame on."""
    w = make_window()
    samples = lambda: [p.render_window.GetMultiSamples() for p in w.plotters]  # noqa: E731
    assert not w.display.options.anti_aliasing and samples() == [0, 0, 0]
    w.set_anti_aliasing(True)
    assert all(n > 1 for n in samples())
    w.set_anti_aliasing(False)
    assert samples() == [0, 0, 0]
