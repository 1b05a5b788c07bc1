"""The physically based skin in the app (issue 27): the skin-model switch, the material
panel, and Play running the simulation in real time (a real window under Xvfb; fixtures:
conftest.py), with the Qt-free playback model behind it (:mod:`wrinkle_vis.app.physics`).
"""

import json

import numpy as np
import pytest

from wrinkle_vis.app.physics import PhysicalPlayback
from wrinkle_vis.app.session import TIMELINE_STEPS, Session
from wrinkle_vis.core.skin import DEFAULT_SKIN_MODEL, SkinMaterial

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")
H = SkinMaterial().time_step


@pytest.fixture(scope="module")
def physical():
    from wrinkle_vis.datasets import load_face

    return load_face().with_skin_model("physical")


def _playback(face, expression="surprise"):
    ex = face.expressions[expression]
    return PhysicalPlayback(ex.at, lambda: ex.duration_s)


# ---------------------------------------------------------------------- Qt-free
def test_ticks_follow_the_wall_clock_in_whole_steps_and_a_slow_frame_is_capped(physical):
    pb = _playback(physical)
    pb.play(physical, 0.0, now=100.0)
    assert pb.time == 0.0 and pb.playing
    assert pb.tick(100.1)  # 0.1 s of wall clock: three steps of 1/30 s
    assert pb.time == pytest.approx(3 * H)
    assert not pb.tick(100.1 + 0.02)  # less than a step: waits...
    assert pb.tick(100.1 + 0.04)  # ...and goes on with what was left
    assert pb.time == pytest.approx(4 * H)
    assert pb.tick(100.14 + 5.0)  # a 5 s stall: at most max_steps steps, the rest dropped
    assert pb.time == pytest.approx((4 + pb.max_steps) * H)
    assert pb.dropped_s == pytest.approx(5.0 - pb.max_steps * H, abs=H)
    pb.pause()
    x = pb.simulation.x.copy()
    assert not pb.tick(200.0) and pb.time == pytest.approx(7 * H)  # paused: nothing moves
    np.testing.assert_array_equal(pb.simulation.x, x)


def _counted(pb):
    """Count the steps ``pb``'s simulations take (each ``advance``), whatever the tick
    says: ``counted[0]`` steps of ``h`` are the simulated seconds, ``counted[0] * H``.
    """
    counted = [0]
    start = pb._start

    def counting_start(*args):
        start(*args)
        advance = pb.simulation.advance

        def counting(dt=None):
            counted[0] += 1
            advance(dt)

        pb.simulation.advance = counting

    pb._start = counting_start
    return counted


@pytest.mark.parametrize("interval", [0.016, 0.045, 0.07])
def test_simulated_time_is_the_wall_clock_time_across_the_end_of_the_timeline(
        physical, interval):
    """Ticks at the app's intervals (a 60 Hz timer; frames of 45 and 70 ms, slower than a
    step) over 1.2 s of wall clock on a 0.5 s timeline that goes round twice: the steps
    taken are the wall-clock time, to within the lag left (less than a step), nothing
    dropped; :attr:`played_s` counts them.
    """
    ex = physical.expressions["surprise"]
    pb = PhysicalPlayback(ex.at, lambda: 0.5)
    counted = _counted(pb)
    pb.play(physical, 0.0, now=10.0)
    ticks = round(1.2 / interval)
    for k in range(1, ticks + 1):
        pb.tick(10.0 + k * interval)
    wall = ticks * interval
    assert 0.0 <= wall - counted[0] * H < H
    assert pb.played_s == pytest.approx(counted[0] * H) and pb.dropped_s == 0.0
    assert pb.time == pytest.approx((counted[0] * H) % (15 * H) or 15 * H)  # went round


def test_play_is_the_simulation_of_the_timeline(physical):
    """Ticks give the states of ``face.simulate`` for the expression's timeline."""
    pb = _playback(physical)
    pb.play(physical, 0.0, now=0.0)
    for k in range(1, 13):
        pb.tick(k * H)
    expected = list(physical.simulate(physical.expressions["surprise"].at, 12 * H, H))[-1]
    assert pb.time == pytest.approx(expected.time)
    np.testing.assert_allclose(pb.state().points, expected.points, rtol=0, atol=1e-9)
    np.testing.assert_allclose(pb.state().W, expected.W, rtol=0, atol=1e-9)


@pytest.mark.parametrize("t", [0.4, 1.5, 2.3])
def test_a_scrub_is_the_re_simulation_from_rest(physical, t):
    """Up to 0.5 s from the start exactly; later from the equilibrium 0.5 s before, within
    1e-3 of the largest displacement of the re-simulation from t = 0.
    """
    pb = _playback(physical)
    pb.scrub(physical, t)
    n = int(np.floor(t / H + 1e-9))
    assert pb.time == pytest.approx(n * H) and pb.resimulated == (n * H <= 0.5)
    sim = physical.simulator(physical.expressions["surprise"].at)
    for _ in range(n):
        sim.advance(H)
    moved = np.abs(sim.x - sim.skin.rest).max()
    assert moved > 0.5  # mm: the expression is under way
    err = np.abs(pb.simulation.x - sim.x).max()
    assert err <= (0.0 if pb.resimulated else 1e-3 * moved)


def test_reset_is_rest_at_time_zero(physical):
    pb = _playback(physical)
    pb.scrub(physical, 1.0)
    pb.reset(physical)
    assert pb.time == 0.0
    np.testing.assert_array_equal(pb.simulation.x, pb.simulation.skin.rest)
    assert not np.any(pb.state().W)


def test_past_the_end_the_timeline_plays_again_from_rest(physical):
    pb = _playback(physical)
    pb.scrub(physical, 3.0 - H)  # surprise lasts 3 s
    pb.play(physical, 3.0 - H, now=0.0)
    pb.tick(2 * H)
    assert pb.time == pytest.approx(H)  # the end, then from rest: one step


def test_the_session_records_the_skin_model_and_the_material_that_differs(wv_face):
    s = Session(wv_face)
    assert s.layout().skin_model is None and s.layout().skin_material == {}  # as before
    s.set_face(s.with_material("membrane_stiffness", 150.0))
    layout = s.layout()
    assert layout.skin_model is None  # the default, which the layout did not record
    assert layout.skin_material == {"membrane_stiffness": 150.0}
    s.set_skin_model("geometric")  # not the default: recorded
    assert s.layout().skin_model == "geometric"
    assert s.layout().skin_material == {"membrane_stiffness": 150.0}
    s.set_skin_model(DEFAULT_SKIN_MODEL)
    assert s.layout().skin_model is None
    with pytest.raises(ValueError, match="membrane_stiffness"):
        s.with_material("membrane_stiffness", -1.0)


# ---------------------------------------------------------------------- the window
class FakeClock:
    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now


@pytest.fixture
def clocked(window):
    """The window with a fake wall clock for the physical skin's Play."""
    window.clock = FakeClock()
    return window


def _physical(window):
    window.skin_box.setCurrentText("physical")
    assert window.session.face.skin_model == "physical"


def _play(window, seconds, ticks):
    """Play and let ``seconds`` of fake wall clock pass in ``ticks`` timer ticks."""
    if not window.play_button.isChecked():
        window.play_button.setChecked(True)
    window.timer.stop()  # the test ticks, with its clock
    for _ in range(ticks):
        window.clock.now += seconds / ticks
        window._tick()


def test_the_skin_switch_shows_the_physical_skin_and_is_an_undoable_edit(window, wv_face):
    """The window opens on the physical skin (the default); the switch to the geometric
    skin and back is an undoable edit."""
    assert DEFAULT_SKIN_MODEL == "physical"
    assert window.skin_box.currentText() == "physical" and window.skin_group.isVisible()
    # copied: a later draw writes into the arrays of the state drawn first (views.py)
    physical_w = window.session.state().W.copy()
    assert window.session.state().skin_model == "physical"
    expected = wv_face.evaluate("surprise", skin="physical")  # the still frame: equilibrium
    np.testing.assert_allclose(physical_w, expected.W, rtol=0, atol=1e-12)
    window.skin_box.setCurrentText("geometric")
    state = window.session.state()
    assert state.skin_model == "geometric" and not window.skin_group.isVisible()
    assert window.session.dirty and window.windowTitle().endswith("*")
    np.testing.assert_array_equal(state.W, wv_face.evaluate("surprise", skin="geometric").W)
    assert np.abs(state.W - physical_w).max() > 1e-3 * np.abs(physical_w).max()
    window.undo_stack.undo()
    assert window.session.face.skin_model == "physical"
    assert window.skin_box.currentText() == "physical" and window.skin_group.isVisible()
    np.testing.assert_allclose(window.session.state().W, physical_w, rtol=0, atol=1e-12)


def test_play_on_the_physical_skin_follows_the_wall_clock(clocked):
    w = clocked
    w.time_slider.setValue(0)
    _physical(w)
    _play(w, 0.5, ticks=30)  # 30 frames of 1/60 s
    s = w.session
    assert s.simulating and s.physics.time == pytest.approx(0.5, abs=H)
    assert w.time_slider.value() == round(TIMELINE_STEPS * s.physics.time / 3.0)
    state = s.state()
    assert state.time == s.physics.time and state.velocities is not None
    expected = list(s.face.simulate(s.current_expression().at, 15 * H, H))[-1]
    np.testing.assert_allclose(state.W, expected.W, rtol=0, atol=1e-9)
    from conftest import skin_mesh

    np.testing.assert_allclose(skin_mesh(w).point_data["W"], state.W, rtol=0, atol=1e-9)


def test_play_refined_guards_the_refined_skin_as_simulate_does(clocked):
    """Play on the physical skin with refinement on: the frame shown is the simulation's
    state refined and then guarded on its refined skin (``face.expression_states`` and
    ``simulate`` with ``refine``), not the coarse skin's guarded state refined, which the
    guard never saw: pucker at 1 s, where the guard acts on the refined skin."""
    w = clocked
    _physical(w)
    w.expression_box.setCurrentText("pucker")
    w.refine_box.setChecked(True)
    w.time_slider.setValue(0)
    _play(w, 1.0, ticks=30)
    s = w.session
    state = s.state()
    expected = next(s.face.expression_states(s.current_expression(), [s.physics.time],
                                             refine=True))
    assert np.count_nonzero(expected.fold_guard) > 0  # the refined skin's guard acts
    assert len(state.points) == len(expected.points) > len(s.face.skin.points)
    np.testing.assert_allclose(state.points, expected.points, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(state.fold_guard, expected.fold_guard)


def test_play_follows_the_wall_clock_from_when_the_simulation_is_ready(clocked):
    """Play on the physical skin, ticked at 45 ms (a frame's time at paper size) across the
    end of the timeline: the simulated seconds (the steps taken, counted) are the
    wall-clock seconds since the simulation was ready, to within a step; the 0.4 s the
    start took (a scrub to 2.7 s simulates its last 0.5 s) is not simulated.
    """
    w = clocked
    _physical(w)
    s = w.session
    counted = _counted(s.physics)
    w.time_slider.setValue(270)  # 2.7 s of 3
    play = s.play

    def slow_play(now):  # starting the simulation takes 0.4 s of wall clock
        play(now)
        w.clock.now += 0.4

    s.play = slow_play
    played0 = s.physics.played_s
    _play(w, 0.02, ticks=1)
    assert counted[0] == 0 and s.physics.time == pytest.approx(2.7)  # 20 ms: no step yet
    _play(w, 0.9, ticks=20)
    assert 0.0 <= 0.92 - counted[0] * H < H and s.physics.dropped_s == 0.0
    assert s.physics.played_s - played0 == pytest.approx(counted[0] * H)
    assert s.physics.time == pytest.approx(2.7 + counted[0] * H - 3.0)  # went round
    assert w.time_slider.value() == round(TIMELINE_STEPS * s.physics.time / 3.0)


def test_pause_keeps_the_state_and_reset_returns_to_rest(clocked, qtbot):
    w = clocked
    w.time_slider.setValue(0)
    _physical(w)
    _play(w, 0.4, ticks=12)
    w.play_button.setChecked(False)  # pause
    s = w.session
    t, points = s.physics.time, s.state().points.copy()
    w.clock.now += 2.0
    qtbot.wait(50)
    w._tick()
    assert s.physics.time == t and s.simulating
    np.testing.assert_array_equal(s.state().points, points)
    assert np.abs(s.state().W).max() > 0.1
    w.reset_button.click()
    assert s.physics.time == 0.0 and w.time_slider.value() == 0
    np.testing.assert_array_equal(s.physics.simulation.x, s.face.skin.points)
    assert not np.any(s.state().W)
    w.time_slider.setValue(150)  # a scrub while paused: re-simulated to 1.5 s
    assert s.physics.time == pytest.approx(1.5) and np.abs(s.state().W).max() > 0.1


def test_a_material_edit_changes_the_simulation_and_is_undoable(clocked):
    w = clocked
    w.time_slider.setValue(0)
    _physical(w)
    _play(w, 0.3, ticks=9)
    s = w.session
    t, before = s.physics.time, s.state().points.copy()
    w.skin_widgets["membrane_stiffness"].setValue(1000.0)  # typed and entered
    assert s.face.material.membrane_stiffness == 1000.0
    assert s.physics.simulation.material.membrane_stiffness == 1000.0
    assert s.physics.time == pytest.approx(t)  # the new skin, simulated to the same time
    assert np.abs(s.state().points - before).max() > 1e-3
    assert w.undo_stack.undoText() == "Set Y (N/m) of the skin to 1000"
    w.undo_stack.undo()
    assert s.physics.simulation.material.membrane_stiffness == 100.0
    assert w.skin_widgets["membrane_stiffness"].value() == 100.0
    np.testing.assert_allclose(s.state().points, before, rtol=0, atol=1e-9)
    w.skin_widgets["biphasic_strain"].setValue(1.5)  # out of range: refused, said why
    assert "biphasic_strain" in w.skin_error.text()
    assert s.face.material.biphasic_strain == 0.3
    assert w.skin_widgets["biphasic_strain"].value() == 0.3


def test_the_skin_model_and_material_are_saved_and_loaded(make_window, tmp_path):
    w = make_window()
    _physical(w)
    w.skin_widgets["membrane_stiffness"].setValue(150.0)
    path = tmp_path / "physical.json"
    assert w.save_as(path)
    data = json.loads(path.read_text())
    assert "skin_model" not in data  # the default, as the built-in layout left it
    assert data["skin_material"] == {"membrane_stiffness": 150.0}
    w.skin_box.setCurrentText("geometric")
    assert w.save_as(tmp_path / "geometric.json")
    data = json.loads((tmp_path / "geometric.json").read_text())
    assert data["skin_model"] == "geometric"
    assert data["skin_material"] == {"membrane_stiffness": 150.0}
    other = make_window()
    assert other.open_layout(tmp_path / "geometric.json")
    assert other.skin_box.currentText() == "geometric" and not other.skin_group.isVisible()
    assert other.open_layout(path)
    assert other.skin_box.currentText() == "physical" and other.skin_group.isVisible()
    assert other.skin_widgets["membrane_stiffness"].value() == 150.0
    face = other.session.face
    assert face.skin_model == "physical" and face.material.membrane_stiffness == 150.0
    assert other.session.state().skin_model == "physical"
    assert not other.session.dirty
