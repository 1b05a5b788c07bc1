"""The physically based skin (core/skin.py, core/simulation.py): analytic cases, stability,
contact and the API."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.core.analysis import dihedral_change
from wrinkle_vis.core.params import ParameterValueError, parameter_table
from wrinkle_vis.core.skin import (
    SkinMaterial,
    SpringSkin,
    activation_response,
    bending_pairs,
    inverted_triangles,
)


def _plate(nx: int = 13, size: float = 40.0):
    """A flat skin and a flat skull 5 mm under it."""
    skin = grid(nx, nx, size)
    skull = wv.TriangleSurface(skin.points - [0.0, 0.0, 5.0], skin.triangles)
    return skin, skull


def _grid_face(nx: int = 21, muscle_kind: str = "linear"):
    skin, skull = _plate(nx, 60.0)
    if muscle_kind == "linear":
        m = wv.LinearMuscle("lin", (-25.0, 0.0, -3.0), (5.0, 0.0, 0.0), radius=40.0,
                            max_angle_deg=40.0, lambda_w=0.3, n_wrinkles=3, k0=1.0,
                            alpha=0.5)
    else:
        m = wv.muscle_types()["ring"]("ring", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=15.0,
                                      strength=3.0, k0=1.0)
    return wv.FaceModel(skin, skull, [m], expressions={})


# ---------------------------------------------------------------- parameters
def test_material_parameters_are_declared_once_with_units_and_ranges():
    params = {p.name: p for p in SkinMaterial.parameters()}
    assert params["attachment_stiffness"].unit == "N/m^3"
    assert params["density"].unit == "kg/m^3" and params["time_step"].unit == "s"
    assert all(p.doc and p.is_number for p in params.values())
    rows = parameter_table(SkinMaterial)
    assert [r[0] for r in rows] == list(params) and rows[0][2] == "N/m"
    assert SkinMaterial.from_dict(SkinMaterial().to_dict()) == SkinMaterial()
    with pytest.raises(ValueError, match=r"^skin density = -1 is outside \(0, inf\)"):
        SkinMaterial(density=-1)
    with pytest.raises(ValueError, match="unknown skin parameter"):
        SkinMaterial.from_dict({"stiffness": 1.0})


def test_the_skin_and_the_muscles_share_one_parameter_check():
    """SkinMaterial and Muscle both validate through Parameter.validate: the same values
    are refused with the same 'allowed' text (a bool is not a number, a count is an
    integer, a range is its metadata's)."""
    damping = {p.name: p for p in SkinMaterial.parameters()}["damping"]
    with pytest.raises(ParameterValueError) as err:
        damping.validate(True)
    assert err.value.allowed == "a real number"
    with pytest.raises(ValueError, match=r"^skin damping = True is not a real number; "):
        SkinMaterial(damping=True)
    with pytest.raises(wv.MuscleParameterError, match="k0 = True is invalid; allowed: a real "
                       "number"):
        wv.LinearMuscle("m", (0, 0, 0), (1, 0, 0), radius=10.0, max_angle_deg=30.0, k0=True)
    with pytest.raises(ValueError, match=r"^skin iterations = 2.5 is not an integer >= 1;"):
        SkinMaterial(iterations=2.5)
    with pytest.raises(wv.MuscleParameterError, match="allowed: an integer >= 1"):
        wv.LinearMuscle("m", (0, 0, 0), (1, 0, 0), radius=10.0, max_angle_deg=30.0,
                        n_wrinkles=2.5)
    assert SkinMaterial(iterations=4.0).iterations == 4  # stored as the checked value
    assert type(SkinMaterial(density=1000).density) is float


def test_unknown_skin_model_is_a_one_line_error():
    face = _grid_face(9)
    with pytest.raises(ValueError, match="unknown skin model 'soft'; choose one of geometric"):
        face.evaluate({"lin": 1.0}, skin="soft")


def test_bending_pairs_join_the_opposite_vertices_of_each_interior_edge():
    tris = np.array([[0, 1, 2], [2, 1, 3]])
    pairs, two = bending_pairs(tris)
    assert sorted(pairs[0].tolist()) == [0, 3] and sorted(two[0].tolist()) == [0, 1]
    assert len(pairs) == 1


# ---------------------------------------------------------------- analytic cases
def test_uniform_pull_on_an_attached_plane_matches_the_closed_form_equilibrium():
    skin, _ = _plate()
    mat = SkinMaterial()
    springs = SpringSkin(skin, np.full(skin.n_points, 0.5), mat, 1e-3)
    d = np.array([2.0, -1.0, 0.5])
    x = springs.equilibrium(np.tile(d, (skin.n_points, 1)))
    # every spring stays at its rest length: kappa_z w / (kappa + kappa_z w) of the pull
    share = 0.5 * mat.muscle_stiffness / (mat.attachment_stiffness + 0.5 * mat.muscle_stiffness)
    np.testing.assert_allclose(x - skin.points, np.tile(share * d, (skin.n_points, 1)),
                               rtol=0.01, atol=1e-9)


def test_uniform_pull_follows_the_damped_oscillator_of_implicit_euler():
    """Springs unstretched, each vertex is the scalar recursion
    (m/h^2 + c m/h + k) x' = m/h^2 (x + h v) + c m/h x + k_z d."""
    skin, _ = _plate(9)
    mat = SkinMaterial(damping=5.0, muscle_stiffness=4e5)
    springs = SpringSkin(skin, np.ones(skin.n_points), mat, 1e-3)
    d, h = 1.5, 1e-3
    target = np.tile([d, 0.0, 0.0], (skin.n_points, 1))
    x, v = skin.points.copy(), np.zeros((skin.n_points, 3))
    m = mat.density * mat.thickness  # per area: every ratio below is per area
    k, kz, c = mat.attachment_stiffness + mat.muscle_stiffness, mat.muscle_stiffness, 5.0
    xs, vs = 0.0, 0.0
    for _ in range(40):
        x, v = springs.step(x, v, target, h)
        new = (m / h**2 * (xs + h * vs) + c * m / h * xs + kz * d) / (m / h**2 + c * m / h + k)
        xs, vs = new, (new - xs) / h
        np.testing.assert_allclose(x[:, 0] - skin.points[:, 0], xs, rtol=1e-6, atol=1e-9)
    assert abs(xs) > 0.1  # it moved


def test_activation_dynamics_are_exact_for_a_held_command():
    a = activation_response(np.array([0.0]), np.array([1.0]), 0.045, 0.045)
    assert a[0] == pytest.approx(1.0 - np.exp(-1.0))
    two = activation_response(activation_response(np.array([0.0]), np.array([1.0]), 0.02,
                                                  0.045), np.array([1.0]), 0.025, 0.045)
    assert two[0] == pytest.approx(a[0])


def test_a_released_muscle_reaches_zero_and_the_skin_its_rest():
    """First-order activation dynamics only approach the command: the release must end at
    exactly 0 (the muscle stops pulling) and the skin at rest."""
    face = _grid_face(11)
    sim = face.simulator(lambda t: {"lin": 1.0 if t < 0.31 else 0.0})
    sim.advance_to(0.3)
    assert sim.activations[0] > 0.99 and np.abs(sim.x - face.skin.points).max() > 0.1
    sim.advance_to(1.0)
    assert (sim.activations == 0.0).all()
    assert not face.simulator(None).muscle_pull().any()
    sim.advance_to(3.0)
    size = np.linalg.norm(np.ptp(face.skin.points, axis=0))
    assert np.abs(sim.x - face.skin.points).max() <= 1e-9 * size
    held = activation_response(np.array([0.99995]), np.array([1.0]), 0.001, 0.045)
    assert held[0] == 1.0  # within the tolerance of its command: the command


def test_a_refined_physical_frame_computes_the_muscles_pull_once(monkeypatch):
    face = _grid_face(15)
    calls = []
    real = face.muscle_displacement
    monkeypatch.setattr(face, "muscle_displacement",
                        lambda acts: calls.append(1) or real(acts))
    state = face.evaluate({"lin": 1.0}, skin="physical", refine=True)
    assert state.face.skin.n_points > face.skin.n_points  # it was refined
    assert len(calls) == 1
    calls.clear()
    sim = face.simulator({"lin": 1.0})
    sim.advance(1.0 / 30.0)
    sim.state()
    assert len(calls) == 1  # the step and its state share the pull


# ---------------------------------------------------------------- stability
def test_zero_activation_stays_at_rest_over_a_thousand_steps():
    face = _grid_face(11)
    sim = face.simulator(None)
    for _ in range(1000):
        sim.step(1.0 / 30.0)
    size = np.linalg.norm(np.ptp(face.skin.points, axis=0))
    assert np.abs(sim.x - face.skin.points).max() <= 1e-9 * size
    assert np.abs(sim.v).max() <= 1e-9 * size


@pytest.mark.parametrize("damping", [0.0, 20.0])
def test_the_free_skin_never_gains_energy(damping):
    """Implicit Euler dissipates; with no damping at a small step it dissipates little, so a
    velocity 1 % too large per step would show."""
    skin, skull = _plate(11)
    springs = SpringSkin(skin, np.zeros(skin.n_points), SkinMaterial(damping=damping), 1e-3,
                         skull)
    rng = np.random.default_rng(4)
    x = skin.points + rng.normal(scale=0.3, size=skin.points.shape) * [1, 1, 0]
    v = rng.normal(scale=20.0, size=skin.points.shape)
    zero = np.zeros_like(x)
    for h in (1e-4, 1.0 / 30.0):
        xs, vs = x, v
        energies = [springs.energy(xs, vs, zero)]
        for _ in range(60):
            xs, vs = springs.step(xs, vs, zero, h)
            energies.append(springs.energy(xs, vs, zero))
        e = np.array(energies)
        assert (np.diff(e) <= 1e-12 * e[0]).all(), h
        assert e[-1] < e[0]


def test_a_step_activation_settles_on_the_still_frame():
    face = _grid_face()
    sim = face.simulator({"lin": 1.0})
    states = list(sim.run(1.5, 1.0 / 30.0))
    still = face.evaluate({"lin": 1.0}, skin="physical")
    assert states[-1].time == pytest.approx(1.5)
    speed = [np.abs(s.velocities).max() for s in states]
    assert speed[-1] < 1e-4 * max(speed)
    assert (np.diff(speed[10:]) < 0).all()  # dying away
    moved = np.abs(still.deformed_points - face.skin.points).max()
    assert moved > 1.0
    assert np.abs(states[-1].deformed_points - still.deformed_points).max() < 1e-3 * moved
    np.testing.assert_allclose(states[-1].W, still.W, atol=1e-3 * np.abs(still.W).max())


def test_halving_the_time_step_changes_a_one_second_trajectory_by_under_two_percent():
    face = _grid_face()

    def ramp(t):
        return {"lin": min(1.0, t / 0.4)}

    def trajectory(dt):
        return {round(s.time, 6): s.deformed_points - face.skin.points
                for s in face.simulate(ramp, 1.0, dt)}

    coarse, fine = trajectory(1.0 / 30.0), trajectory(1.0 / 60.0)
    scale = max(np.abs(d).max() for d in fine.values())
    err = max(np.abs(coarse[t] - fine[t]).max() for t in coarse)
    assert len(coarse) == 30 and scale > 1.0
    assert err < 0.02 * scale


# ---------------------------------------------------------------- the API
def test_every_field_is_computed_on_the_simulated_skin_by_the_geometric_code():
    face = _grid_face()
    phys = face.evaluate({"lin": 1.0}, skin="physical")
    geo = face.evaluate({"lin": 1.0}, skin="geometric")
    assert phys.skin_model == "physical" and geo.skin_model == "geometric"
    data = face.muscle_data(face.muscle("lin"))
    eps = phys.fields["lin"]["eps"][data.aoi]
    np.testing.assert_allclose(eps, data.compression(face.skin, phys.deformed_points),
                               atol=1e-12)
    assert not np.allclose(eps, geo.fields["lin"]["eps"][data.aoi])
    # the physical skin moves outside the muscle's area of influence too (it relaxes)
    outside = np.setdiff1d(np.arange(face.skin.n_points), data.aoi)
    assert np.abs(geo.deformed_points[outside] - face.skin.points[outside]).max() == 0.0
    assert np.abs(phys.deformed_points[outside] - face.skin.points[outside]).max() > 1e-3
    w = phys.fields["lin"]["W"]
    np.testing.assert_allclose(np.nan_to_num(w), phys.W, atol=1e-12)


def test_simulate_takes_names_mappings_and_callables_and_the_simulator_resets():
    face = _grid_face(13).with_expressions(
        {"pull": wv.Expression("pull", {"lin": 1.0})})
    by_name = [s.W.max() for s in face.simulate("pull", 0.2, 0.05)]
    by_map = [s.W.max() for s in face.simulate({"lin": 1.0}, 0.2, 0.05)]
    by_call = [s.W.max() for s in face.simulate(lambda t: {"lin": 1.0}, 0.2, 0.05)]
    assert by_name == by_map == by_call and by_name[-1] > 0
    sim = face.simulator("pull")
    first = sim.step(0.05)
    assert first.time == pytest.approx(0.05) and first.velocities.shape == (face.skin.n_points, 3)
    sim.step(0.05)
    sim.reset()
    assert sim.time == 0.0 and np.array_equal(sim.x, face.skin.points)
    np.testing.assert_array_equal(sim.step(0.05).points, first.points)
    with pytest.raises(ValueError, match="time step dt"):
        sim.step(0.0)


def test_a_plugin_muscle_type_drives_the_physical_skin_with_no_code_of_its_own():
    face = _grid_face(21, "ring")
    state = face.evaluate({"ring": 1.0}, skin="physical")
    w = state.fields["ring"]["W"]
    assert np.nanmax(np.abs(w)) > 0
    r = np.linalg.norm(face.skin.points[:, :2], axis=1)
    # the ring pulls the skin inward; the skin outside the ring follows a little
    radial = np.einsum("ij,ij->i", (state.deformed_points - face.skin.points)[:, :2],
                       face.skin.points[:, :2]) / np.maximum(r, 1e-9)
    assert radial[(r > 5) & (r < 12)].mean() < -0.1
    assert radial[(r > 17) & (r < 22)].mean() < -1e-3


# ---------------------------------------------------------------- contact and folds
def _check_frame(state, skull_distance, rest_distance) -> None:
    assert inverted_triangles(state.rest_points, state.deformed_points, state.triangles) == 0
    d = skull_distance(state.deformed_points)
    assert (d >= np.minimum(rest_distance, 0.0) - 1e-6).all()


@pytest.fixture(scope="module")
def skull_distance():
    pv = pytest.importorskip("pyvista")
    vtk = pytest.importorskip("vtk")
    face = wv.datasets.load_face()
    skull = pv.PolyData.from_regular_faces(face.skull.points, face.skull.triangles)
    implicit = vtk.vtkImplicitPolyDataDistance()
    implicit.SetInput(skull)

    def distance(points):  # positive outside the skull (VTK's sign is negative inside)
        return np.array([implicit.EvaluateFunction(p) for p in points])

    return face, distance, distance(face.skin.points)


def test_built_in_expressions_never_enter_the_skull_nor_fold(skull_distance):
    face, distance, rest = skull_distance
    for name in ("surprise", "frown", "fear"):
        for state in face.simulate(name, 0.2, 0.05):
            _check_frame(state, distance, rest)
        _check_frame(face.evaluate(name, skin="physical"), distance, rest)


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**16), strength=st.floats(1.0, 3.0))
@example(seed=5, strength=3.0)  # turned a triangle over near the jaw before the fold guard
def test_random_activations_up_to_three_times_the_strength_never_enter_nor_fold(
        skull_distance, seed, strength):
    face, distance, rest = skull_distance
    strong, acts = _stronger(face, strength, seed)
    for state in strong.simulate(acts, 0.15, 0.05):
        _check_frame(state, distance, rest)


def _stronger(face, strength: float, seed: int):
    """``(face, activations)``: ``face`` with every muscle ``strength`` times as strong (or
    the strongest its type allows) and random activations in [0, 1] from ``seed``."""
    muscles = []
    for m in face.muscles:
        try:
            muscles.append(dataclasses.replace(m, strength=strength * m.strength_value))
        except ValueError:  # past the type's own bound: the strongest it allows
            muscles.append(dataclasses.replace(m, strength=0.99 * m.strength_value
                                               * _max_factor(m)))
    strong = wv.FaceModel(face.skin, face.skull, muscles, face.expressions, name="strong",
                          unit=face.unit)
    acts = dict(zip(strong.muscle_names,
                    np.random.default_rng(seed).uniform(0, 1, len(muscles)), strict=True))
    return strong, acts


def _max_factor(m) -> float:
    """The largest factor in [1, 3] that muscle ``m``'s type allows on its strength."""
    lo, hi = 1.0, 3.0
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        try:
            dataclasses.replace(m, strength=mid * m.strength_value)
            lo = mid
        except ValueError:
            hi = mid
    return lo


def test_a_step_to_surprise_forms_its_wrinkles_in_50_to_300_ms_without_overshoot():
    face = wv.datasets.load_face()
    for dt in (0.01, None):  # None: the default step, 1/30 s
        states = list(face.simulate("surprise", 0.6, dt))
        w = np.array([np.abs(s.W).sum() for s in states])
        t = np.array([s.time for s in states])
        final = w[-1]
        reach = t[np.argmax(w >= 0.9 * final)]
        assert 0.05 <= reach <= 0.3, dt
        assert w.max() <= 1.1 * final


def _winding(surface, x):
    """``(k,)``: the winding number of closed ``surface`` about points ``x`` ``(k, 3)``
    (Van Oosterom and Strackee's solid angles over 4 pi): 1 inside, 0 outside, exactly."""
    a, b, c = (surface.points[surface.triangles[:, i]][None] - x[:, None] for i in range(3))
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    det = np.einsum("kmi,kmi->km", a, np.cross(b, c))
    div = (la * lb * lc + np.einsum("kmi,kmi->km", a, b) * lc
           + np.einsum("kmi,kmi->km", b, c) * la + np.einsum("kmi,kmi->km", c, a) * lb)
    return (2.0 * np.arctan2(det, div)).sum(axis=1) / (4.0 * np.pi)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**16))
@example(seed=1)
@example(seed=49268)
def test_the_skulls_side_of_a_point_is_its_winding_number(seed):
    """The skull contact's sign (``_Skull.distance``) says inside exactly where the winding
    number does, on a bumpy closed surface with concave creases, for points within about a
    twentieth of an edge of it: the vertex normals interpolated across a triangle called a
    point in front of it inside (3 of the scanned head's skin vertices at rest; seed 1 and
    11 of the first 20 seeds failed so); and the closest point taken among the triangles
    around the four nearest vertices only is not the closest on so uneven a surface (seed
    49268: a point 0.2 mm inside called 1.7 mm outside)."""
    from meshes import sphere

    from wrinkle_vis.core.skin import _Skull

    rng = np.random.default_rng(seed)
    ball = sphere(2, 10.0)
    bumps = ball.points * (1.0 + 0.6 * rng.uniform(-1, 1, (ball.n_points, 1)))
    skull = wv.TriangleSurface(bumps, ball.triangles)
    tri = rng.integers(skull.n_triangles, size=300)
    bary = rng.dirichlet(np.ones(3), size=300)
    on = np.einsum("kj,kjd->kd", bary, skull.points[skull.triangles[tri]])
    x = on + rng.normal(0.0, 0.05 * skull.mean_edge_length, (300, 3))
    inside = _winding(skull, x) > 0.5
    s = _Skull(skull, x).distance(x)[0]
    assert np.array_equal(s < 0.0, inside)


def test_a_pull_into_the_skull_stops_on_it():
    skin, skull = _plate(9)
    springs = SpringSkin(skin, np.ones(skin.n_points), SkinMaterial(), 1e-3, skull)
    into = np.tile([0.0, 0.0, -12.0], (skin.n_points, 1))
    x, v = skin.points.copy(), np.zeros_like(skin.points)
    for _ in range(5):
        x, v = springs.step(x, v, into, 1.0 / 30.0)
        assert x[:, 2].min() >= -5.0 - 1e-9
    assert x[:, 2].min() == pytest.approx(-5.0)
    assert springs.equilibrium(into)[:, 2].min() >= -5.0 - 1e-9


def test_skin_inside_the_skull_at_rest_is_free_and_measured_once():
    """Where a scan's skull reaches through its skin, the vertices inside it at rest are
    free: they follow the pull, and after their rest distance is measured the projection
    never measures them again (on the scanned head this was most of a step)."""
    skin = grid(9, 9, 40.0)
    skull = wv.TriangleSurface(skin.points + [0.0, 0.0, 5.0], skin.triangles)  # above it
    springs = SpringSkin(skin, np.ones(skin.n_points), SkinMaterial(), 1e-3, skull)
    asked = []
    measure = springs.skull.distance
    springs.skull.distance = lambda x: asked.append(len(x)) or measure(x)
    pull = np.tile([0.0, 0.0, -2.0], (skin.n_points, 1))
    x, v = springs.step(skin.points.copy(), np.zeros_like(skin.points), pull, 1.0 / 30.0)
    assert asked  # looked at once
    asked.clear()
    for _ in range(4):
        x, v = springs.step(x, v, pull, 1.0 / 30.0)
    assert x[:, 2].max() < -1.0  # free: deeper into the skull with the pull
    assert sum(asked) == 0


def test_refinement_carries_the_simulated_displacement_to_new_vertices():
    # a looser grip than the default, so that the springs add a good deal to the pull
    face = _grid_face(25).with_skin_model("physical", SkinMaterial(muscle_stiffness=1e8))
    flat = face.evaluate({"lin": 1.0})
    state = face.evaluate({"lin": 1.0}, refine=True, refine_angle_deg=1.0)
    n0 = face.skin.n_points
    assert state.n_points > n0 + 50 and state.skin_model == "physical"
    np.testing.assert_array_equal(state.deformed_points[:n0], flat.deformed_points)
    # new vertices move with their neighbours (the geometric pull alone would leave them
    # behind by up to the 1.7 mm the springs add, folding triangles over)
    surface = state.face.skin
    change = dihedral_change(surface, surface.points, state.deformed_points)
    assert np.nanmax(change) <= 5.0
    assert inverted_triangles(surface.points, state.deformed_points, surface.triangles) == 0
    added = (state.deformed_points - surface.points
             - state.face.muscle_displacement(state.activations))
    assert np.abs(added[n0:]).max() > 0.1
    frames = list(face.simulate({"lin": 1.0}, 0.1, 0.05, refine=True, refine_angle_deg=1.0))
    assert [round(s.time, 6) for s in frames] == [0.05, 0.1]
    assert all(s.n_points > n0 and s.skin_model == "physical" for s in frames)


# ---------------------------------------------------------------- layout files
def test_a_layout_records_the_skin_model_and_its_material(tmp_path):
    from wrinkle_vis.core.layout import Layout, LayoutError, load_layout, save_layout

    path = tmp_path / "phys.json"
    save_layout(Layout(skin_model="physical", skin_material={"membrane_stiffness": 150.0}),
                path)
    layout = load_layout(path)
    assert layout.skin_model == "physical"
    assert layout.material() == SkinMaterial(membrane_stiffness=150.0)
    data = layout.to_dict()
    data["skin_material"] = {"density": -3}
    with pytest.raises(LayoutError, match=r"\$\.skin_material\.density: expected density "
                                          r"\(ρ, density of the soft tissue\) in \(0, inf\)"):
        Layout.from_dict(data)
    data["skin_material"] = {"stiffness": 1}
    with pytest.raises(LayoutError, match=r"\$\.skin_material\.stiffness: expected one of"):
        Layout.from_dict(data)
    data["skin_material"], data["skin_model"] = {}, "soft"
    with pytest.raises(LayoutError, match=r"\$\.skin_model: expected a skin model"):
        Layout.from_dict(data)


def test_load_face_applies_the_layouts_skin_model():
    from wrinkle_vis.core.layout import load_layout
    from wrinkle_vis.core.skin import DEFAULT_SKIN_MODEL
    from wrinkle_vis.datasets.face import BUILTIN_LAYOUT

    other = "geometric" if DEFAULT_SKIN_MODEL == "physical" else "physical"
    layout = dataclasses.replace(load_layout(BUILTIN_LAYOUT), skin_model=other,
                                 skin_material={"damping": 5.0})
    face = wv.datasets.load_face(layout=layout)
    assert face.skin_model == other and face.material.damping == 5.0
    state = face.evaluate("frown")
    assert state.skin_model == other
    assert wv.datasets.load_face().skin_model == DEFAULT_SKIN_MODEL


def test_the_scanned_head_neither_folds_nor_enters_its_skull(scanned_head):
    """The Lee Perry-Smith skull reaches through the scan's skin in places (vertices inside
    it at rest are left free); every other vertex stays outside, and nothing folds."""
    pv = pytest.importorskip("pyvista")
    vtk = pytest.importorskip("vtk")
    face = scanned_head
    implicit = vtk.vtkImplicitPolyDataDistance()
    implicit.SetInput(pv.PolyData.from_regular_faces(face.skull.points, face.skull.triangles))

    def distance(points):
        return np.array([implicit.EvaluateFunction(p) for p in points])

    outside = distance(face.skin.points) > 0.5  # clear of the skull at rest
    for name in ("surprise", "frown", "fear"):
        state = face.evaluate(name, skin="physical")
        assert inverted_triangles(state.rest_points, state.deformed_points,
                                  state.triangles) == 0, name
        # (VTK's sign flips at one vertex by the nose that hardly moves: look at the
        # vertices that move by 0.01 mm or more)
        moved = outside & (np.abs(state.deformed_points - face.skin.points).max(axis=1) > 0.01)
        assert moved.sum() > 20
        assert (distance(state.deformed_points[moved]) >= -1e-6).all(), name


# ---------------------------------------------------------------- realism
def _crease(state, floor: float = 0.01) -> np.ndarray:
    """The change of the dihedral angles (deg) that the deformation alone adds, on the edges
    with a vertex moved by more than ``floor`` mm. The physical skin moves every vertex a
    little (tests/test_realism.py's ``crease`` takes every moved edge, which would dilute
    the percentile with the still skin); 0.01 mm keeps the zones and the skin relaxing
    around them.
    """
    surface, rest = state.face.skin, state.rest_points
    moved = np.linalg.norm(state.deformed_points - rest, axis=1) > floor
    change = dihedral_change(surface, rest, state.deformed_points)
    change = change[moved[surface.edges].any(axis=1)]
    return change[np.isfinite(change)]


def _no_plateau_edge(face, refine: bool = False) -> None:
    """Issue 27: the deformation adds a crease of at most 8 degrees at the 99th percentile,
    for each of surprise, frown and fear, on the physical skin."""
    for name in ("surprise", "frown", "fear"):
        change = _crease(face.evaluate(name, skin="physical", refine=refine))
        assert len(change) > 50, name
        assert np.percentile(change, 99) <= 8.0, (name, np.percentile(change, 99))


def test_the_physical_skin_meets_the_paper_size_realism_checks():
    """Surprise and frown refined on the physical skin pass the project's realism checks
    (tests/test_realism.py: n_w crests on six lines, two furrows of 60 mm, median depth
    0.6 mm, 85 % of the normal's change across the fibres; furrows between the brows), and
    the deformation adds no crease past 8 degrees at the 99th percentile."""
    from test_realism import check_forehead, check_glabella

    face = wv.datasets.load_face()
    check_forehead(face.evaluate("surprise", skin="physical", refine=True))
    check_glabella(face.evaluate("frown", skin="physical", refine=True))
    _no_plateau_edge(face, refine=True)


@pytest.mark.slow
def test_the_physical_skin_meets_the_realism_checks_on_the_60k_face(procedural_at):
    from test_realism import check_forehead, check_glabella

    face = procedural_at(60000)
    check_forehead(face.evaluate("surprise", skin="physical"))
    check_glabella(face.evaluate("frown", skin="physical"))
    _no_plateau_edge(face)


@pytest.mark.slow
def test_the_physical_skin_adds_no_plateau_edge_on_the_scanned_head(scanned_head):
    _no_plateau_edge(scanned_head)


# ---------------------------------------------------------------- convergence
def _difference(fine, where, a, b, scheme) -> np.ndarray:
    """``(n_coarse,)``: ``|a - b(p)|`` with ``a`` ``(n_coarse, 3)`` at the coarse face's rest
    vertices and ``b`` ``(n_fine, 3)`` interpolated at their closest points on the fine rest
    skin (``where``, ``surface_coordinates``' triangles and weights) by ``scheme``,
    ``barycentric_points`` (linear) or ``quadratic_points`` (a local quadratic fit) of
    core/mesh.py."""
    return np.linalg.norm(a - scheme(fine.skin, *where, b), axis=1)


def _closed_form_pull(face, activations) -> np.ndarray:
    """``(n, 3)``: the muscles' closed-form pull (``Muscle.unit_displacement``, a function
    of the rest position alone) at the face's rest vertices."""
    return sum(a * face.muscle(n).unit_displacement(face.skin.points)
               for n, a in activations.items() if a > 0.0)


@pytest.mark.slow
def test_the_equilibrium_converges_from_the_20k_to_the_60k_face(procedural_at):
    """Issue 27: the 20k and 60k equilibria agree within 5 % and the forehead's furrows
    within a tenth of a period (docs/model.md, "Across resolutions").

    At each 20k vertex moving by 10 % or more of the largest displacement, the 60k
    displacement is interpolated at the vertex's closest point on the 60k rest skin, and
    the difference is taken in units of the largest displacement. Linear interpolation
    misses 5 % on the frown (6.8 %) by its own error: the corrugator's pull falls from its
    peak to 0 over 3.4 mm, two 60k edges. The local quadratic fit (``quadratic_points``)
    is checked first on the muscles' closed-form pull, whose exact value at the 20k vertex
    is known: it halves linear interpolation's error there (surprise 1.8 -> 0.56 %,
    frown 10.6 -> 4.5 %; the rest of the frown's is the 60k sampling of that fall, which
    no local fit recovers, and which moves with the 60k tiling: 7.8 -> 3.8 % on the even
    skin before stop 37 graded it). With it the whole displacement agrees within 5 % at every
    moving vertex. The 60k equilibrium rebuilt as the pull at the 20k vertex plus the 60k
    spring response (equilibrium minus pull) interpolated linearly, which is how the 60k
    face's own refinement carries it to a new point (core/refined.py), agrees within 2 %.
    """
    from test_realism import forehead_rows

    from wrinkle_vis.core.mesh import barycentric_points, quadratic_points, surface_coordinates

    coarse, fine = procedural_at(20000), procedural_at(60000)
    where = surface_coordinates(fine.skin, coarse.skin.points)
    period = 2.0 * coarse.muscle("frontalis_inner_L").u
    for name, pull_bound in (("surprise", 0.01), ("frown", 0.05)):
        sc, sf = (f.evaluate(name, skin="physical") for f in (coarse, fine))
        uc = sc.deformed_points - coarse.skin.points
        uf = sf.deformed_points - fine.skin.points
        top = np.linalg.norm(uc, axis=1).max()
        keep = np.linalg.norm(uc, axis=1) >= 0.1 * top
        pc, pf = (_closed_form_pull(f, sc.activations) for f in (coarse, fine))
        linear, quadratic = (_difference(fine, where, pc, pf, s)[keep] / top
                             for s in (barycentric_points, quadratic_points))
        assert quadratic.max() <= min(pull_bound, 0.6 * linear.max()), (name, quadratic.max())
        whole = _difference(fine, where, uc, uf, quadratic_points)[keep] / top
        assert whole.max() <= 0.05, (name, whole.max())
        assert np.sqrt(np.mean(whole**2)) <= 0.015, name
        dc, df = (f.muscle_displacement(s.activations) for f, s in ((coarse, sc), (fine, sf)))
        rebuilt = _difference(fine, where, uc - dc, uf - df, barycentric_points)[keep] / top
        assert rebuilt.max() <= 0.02, (name, rebuilt.max())
        if name == "surprise":
            for a, b in zip(forehead_rows(sf), forehead_rows(sc), strict=True):
                assert a["crests"] == 3  # on the 60k face
                for p in a["furrow_points"][np.asarray(a["depths"]) > 0.3]:
                    gap = np.linalg.norm(b["furrow_points"] - p, axis=1).min()
                    assert gap <= 0.1 * period, (a["offset"], p, gap)


# ---------------------------------------------------------------- both built-in faces
#: The share of the scanned head's skin vertices that may lie inside its skull at rest
#: (VTK's signed distance): 762 of 8,844 (8.6 %) when measured, in three patches where the
#: skull reaches through the scan's skin (the eye sockets, 304 and 244, and the mouth and
#: chin, 214). The physical skin leaves them free by design, so they are exempt from
#: "never inside".
HEAD_INSIDE_AT_REST = 0.1


def _skull_check(face):
    """``(check, inside)``: ``check(state)`` asserts that no triangle of the frame turned
    over and that no vertex outside ``face``'s skull at rest is inside it; ``inside``
    ``(n,) bool``, the vertices inside at rest (exempt)."""
    pv = pytest.importorskip("pyvista")
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy

    implicit = vtk.vtkImplicitPolyDataDistance()
    implicit.SetInput(pv.PolyData.from_regular_faces(face.skull.points, face.skull.triangles))

    def distance(points):  # positive outside the skull
        out = vtk.vtkDoubleArray()
        implicit.FunctionValue(numpy_to_vtk(np.ascontiguousarray(points, dtype=float)), out)
        return vtk_to_numpy(out).copy()

    enclosed = vtk.vtkSelectEnclosedPoints()  # ray parity: the skull is closed
    enclosed.Initialize(pv.PolyData.from_regular_faces(face.skull.points,
                                                       face.skull.triangles))
    inside = distance(face.skin.points) < 0.0

    def check(state, label) -> None:
        assert inverted_triangles(state.rest_points, state.deformed_points,
                                  state.triangles) == 0, label
        points = state.deformed_points[~inside]
        d = distance(points)
        # VTK's sign flips now and then at a point whose closest skull point is a vertex
        # (one 7.4 mm out by the scanned head's nose reads -7.4, then +7.4 when moved by
        # 1e-6): a negative distance counts only where ray parity agrees
        entered = [i for i in np.flatnonzero(d < -1e-6) if enclosed.IsInsideSurface(*points[i])]
        assert not entered, (label, len(entered), d[entered].min())

    return check, inside


@pytest.mark.slow
@pytest.mark.parametrize("name", ["procedural", "lee_perry_smith"])
def test_every_built_in_expression_neither_enters_the_skull_nor_folds_at_any_frame(
        name, wv_face, scanned_head):
    """Issue 27: no skin vertex inside the skull and no inverted triangle at any frame, for
    every built-in expression (a step to it, 0.2 s in 0.05 s steps, and the still frame),
    on both built-in faces; on the scanned head the vertices inside its skull at rest are
    exempt (762 of 8,844, :data:`HEAD_INSIDE_AT_REST`)."""
    face = wv_face.with_skin_model(wv_face.skin_model) if name == "procedural" else scanned_head
    check, inside = _skull_check(face)
    assert inside.mean() <= (0.0 if name == "procedural" else HEAD_INSIDE_AT_REST)
    assert len(face.expressions) >= 14
    for expression in sorted(face.expressions):
        for state in face.simulate(expression, 0.2, 0.05):
            check(state, (expression, state.time))
        check(face.evaluate(expression, skin="physical"), expression)


@pytest.fixture(scope="module")
def scanned_head(wv_head):
    """The scanned head, sharing the session's caches (conftest's ``wv_head``)."""
    return wv_head.with_skin_model(wv_head.skin_model)


@pytest.fixture(scope="module")
def head(scanned_head):
    return scanned_head, *_skull_check(scanned_head)


@pytest.mark.slow
@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**16), strength=st.floats(1.0, 3.0))
@example(seed=5, strength=3.0)
@example(seed=860, strength=2.0)  # the skull contact called a vertex in front of it inside
def test_random_activations_up_to_three_times_the_strength_on_the_scanned_head(
        head, seed, strength):
    """The property test above on the scanned head: random activations in [0, 1] with every
    muscle up to 3x its strength (or the strongest its type allows) never push a vertex
    outside the skull at rest into it nor turn a triangle over, at any frame."""
    face, check, _ = head
    strong, acts = _stronger(face, strength, seed)
    for state in strong.simulate(acts, 0.15, 0.05):
        check(state, (seed, strength, state.time))


@pytest.mark.slow
def test_the_scanned_head_meets_the_dynamic_targets(scanned_head):
    """Issue 27's dynamic targets on the scanned head (tests above on small faces): a step
    to surprise forms its wrinkles (the sum of |W|) to 90 % within 50-300 ms at both steps
    with at most 10 % overshoot and settles on the still frame; halving the step changes a
    1 s ramp by under 2 %; the damped free skin released from the surprise equilibrium
    never gains energy."""
    face = scanned_head
    for dt in (0.01, None):
        states = list(face.simulate("surprise", 0.6, dt))
        w = np.array([np.abs(s.W).sum() for s in states])
        t = np.array([s.time for s in states])
        assert 0.05 <= t[np.argmax(w >= 0.9 * w[-1])] <= 0.3, dt
        assert w.max() <= 1.1 * w[-1], dt
    still = face.evaluate("surprise", skin="physical")
    moved = np.abs(still.deformed_points - face.skin.points).max()
    assert np.abs(states[-1].deformed_points - still.deformed_points).max() <= 1e-2 * moved
    acts = face.activations_for("surprise")

    def trajectory(dt):
        sim = face.simulator(lambda t: {m: a * min(1.0, t / 0.4) for m, a in acts.items()})
        out = {}
        while sim.time < 1.0 - 1e-9:
            sim.advance(dt)
            out[round(sim.time, 6)] = sim.x - face.skin.points
        return out

    coarse, fine = trajectory(1.0 / 30.0), trajectory(1.0 / 60.0)
    scale = max(np.abs(d).max() for d in fine.values())
    assert len(coarse) == 30 and scale > 1.0
    assert max(np.abs(coarse[t] - fine[t]).max() for t in coarse) < 0.02 * scale
    sim = face.simulator(None)
    sim.x = face.physical_skin().equilibrium(face.muscle_displacement(acts))
    energies = [sim.energy()]
    for _ in range(60):
        sim.advance(1.0 / 30.0)
        energies.append(sim.energy())
    e = np.array(energies)
    assert (np.diff(e) <= 1e-12 * e[0]).all() and e[-1] < 0.5 * e[0]
