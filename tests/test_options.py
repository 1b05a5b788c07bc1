"""The two per-muscle options, off by default (docs/model.md, "Two options, off by default"):
``taper``, a C1 taper of H over the wrinkling region's first and last half period, and
``compression="gradient"``, epsilon from the deformation gradient instead of Eq. 10.
"""

import dataclasses
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from meshes import grid, rotation

import wrinkle_vis as wv
from wrinkle_vis.core.equations import gradient_compression
from wrinkle_vis.core.muscle import OPTIONS, Muscle

H_STEP = 80.0 / 60  # the spacing of grid(61, 61, 80.0)


def sheet(name="sh", **kw):
    """A sheet on the flat grid, fibre along +x: L_s = 50, R_s = 40, W_s = 24, h_c = 6."""
    return wv.SheetMuscle(name, ((-30, -12, 0), (-30, 12, 0)), ((10, -12, 0), (10, 12, 0)),
                          lambda_w=0.3, n_wrinkles=2, k0=1.0, **kw)


def linear(name="lin", **kw):
    return wv.LinearMuscle(name, (-30, 0, 0), (0, 0, 0), radius=45.0, max_angle_deg=30.0,
                           lambda_w=0.3, n_wrinkles=3, k0=1.0, **kw)


def ring(name="ring", **kw):
    return wv.muscle_from_dict({"type": "ring", "name": name, "center": [0, 0, 0],
                                "axis": [0, 0, 1], "radius": 20.0, "k0": 1.0, **kw})


MAKERS = {"linear": linear, "sheet": sheet, "ring": ring}


def ramp_strain(m, activation=1.0):
    r"""The analytic compression of the sheet's pull where its ramp is linear and it is
    uniform across: the displacement is :math:`-a K m (l - \sigma/2) f`, an affine map that
    shortens the fibre direction by :math:`a K m` (``ramp_fall``)."""
    peak, end = m.fall_start_value, m.length_value
    sigma = min(0.5 * (end - peak), 0.5 * peak)
    return activation * m.strength_value / (peak - sigma), sigma


@pytest.fixture(scope="module")
def flat():
    return grid(61, 61, 80.0)


# ---------------------------------------------------------------------- declared once
@pytest.mark.parametrize("kind", list(MAKERS))
def test_every_type_has_both_options_off_by_default(kind):
    m = MAKERS[kind]()
    assert m.taper is False and m.compression == "edges"
    assert set(OPTIONS) == {"taper", "compression"}
    for cls in type(m).__mro__:  # declared once, on the base, keyword-only
        if cls is not Muscle and dataclasses.is_dataclass(cls):
            assert not set(OPTIONS) & set(cls.__dict__.get("__annotations__", {}))
    fields = {f.name: f for f in dataclasses.fields(m)}
    assert fields["taper"].kw_only and fields["compression"].kw_only
    on = MAKERS[kind](taper=True, compression="gradient")
    assert on.taper is True and on.compression == "gradient"
    assert m.replace(taper=np.bool_(True)).taper is True  # numpy bools are bools


@pytest.mark.parametrize("kind", list(MAKERS))
@pytest.mark.parametrize(("param", "value", "allowed"), [
    ("taper", "yes", "True or False"), ("taper", 1, "True or False"),
    ("taper", None, "True or False"),
    ("compression", "Gradient", "'edges' or 'gradient'"),
    ("compression", "cotangent", "'edges' or 'gradient'"),
    ("compression", None, "'edges' or 'gradient'")])
def test_a_bad_option_names_muscle_parameter_value_and_allowed_values(kind, param, value,
                                                                      allowed):
    with pytest.raises(wv.MuscleParameterError) as info:
        MAKERS[kind]("m1", **{param: value})
    msg = str(info.value)
    assert info.value.param == param
    assert "'m1'" in msg and f"parameter {param} = {value!r}" in msg
    assert msg.endswith(f"allowed: {allowed}")


# ---------------------------------------------------------------------- taper
@pytest.mark.parametrize("kind", list(MAKERS))
def test_without_taper_H_is_eq5_exactly(kind, flat):
    m = MAKERS[kind]()
    reg = m.region(flat.points)
    assert reg.in_region.sum() > 50
    np.testing.assert_array_equal(reg.H, wv.shape_function(reg.w, m.u, m.k0, m.alpha))


def along_fibre(m, l):
    """Points at distances ``l`` from the attachment along the central fibre."""
    if isinstance(m, wv.SheetMuscle):
        start, f = m.attachment_center, m.frame[0]
    elif isinstance(m, wv.LinearMuscle):
        start, f = np.asarray(m.attachment), m.fibre
    else:  # ring: l is the distance from the centre, in the ring's plane
        start, f = np.asarray(m.center), np.array([1.0, 0.0, 0.0])
    return start + np.asarray(l)[:, None] * f


@pytest.mark.parametrize("kind", list(MAKERS))
def test_taper_starts_and_ends_H_at_zero_with_zero_slope_and_keeps_eq5_inside(kind):
    m = MAKERS[kind](taper=True)
    plain = m.replace(taper=False)
    big_r, u = m.wrinkle_length, m.u
    start, end = m.lambda_w * big_r, big_r
    l = np.linspace(start, end, 4001)
    reg, ref = m.region(along_fibre(m, l)), plain.region(along_fibre(m, l))
    assert reg.in_region.all()
    assert abs(ref.H[0]) > 0.5 * m.k0 and abs(ref.H[-1]) > 0.5 * m.k0  # Eq. 5 jumps there
    assert abs(reg.H[0]) < 1e-12 and abs(reg.H[-1]) < 1e-12
    # zero slope: within delta of either end |H| <= (pi delta / 2u)^2 max|H|
    delta = l[1] - l[0]
    bound = (np.pi * delta / (2 * u)) ** 2 * m.k0 * 2 ** m.alpha
    assert abs(reg.H[1]) <= bound and abs(reg.H[-2]) <= bound
    s = l - start
    inside = (s > u + 1e-6) & (s < end - start - u - 1e-6)
    np.testing.assert_array_equal(reg.H[inside], ref.H[inside])
    assert np.all(np.abs(reg.H) <= np.abs(ref.H) + 1e-15)
    t = m.taper_profile(l)
    np.testing.assert_allclose(reg.H, t * ref.H, rtol=0, atol=1e-12)
    # the profile: sin^2 rise over the first half period, its mirror over the last
    first = s <= u
    np.testing.assert_allclose(t[first], np.sin(0.5 * np.pi * s[first] / u) ** 2, atol=1e-12)


@pytest.mark.parametrize("kind", ["sheet", "linear"])
def test_taper_takes_the_jump_out_of_W_at_the_region_boundary(kind, flat):
    jumps = {}
    for taper in (False, True):
        m = MAKERS[kind](taper=taper)
        state = wv.FaceModel(flat, None, [m]).evaluate({m.name: 1.0})
        reg = m.region(flat.points)
        inr = reg.in_region
        e = flat.edges
        jump = np.abs(state.W[e[:, 0]] - state.W[e[:, 1]])
        # across the region's ends (lambda = lambda_w or 1); at its sides At falls to 0
        across = (inr[e[:, 0]] != inr[e[:, 1]]) & (reg.gamma[e] < 1.0).all(axis=1)
        inside = inr[e[:, 0]] & inr[e[:, 1]]
        jumps[taper] = jump[across], jump[inside].max()
        f = state.fields[m.name]  # W = H A At holds with the tapered H
        np.testing.assert_allclose(f["W"], f["H"] * f["A"] * f["At"], equal_nan=True,
                                   atol=1e-15)
    (off, _), (on, inside_on) = jumps[False], jumps[True]
    assert off.max() > 0.1  # the paper's H: W jumps to the furrow bottom at the region's start
    # tapered, the step is second order in the mesh size: the vertex inside is at most one
    # grid step h from the end, where the taper is at most (pi h / 2u)^2
    assert np.all(on <= (np.pi * H_STEP / (2 * m.u)) ** 2 * off + 1e-15)
    assert on.max() < 0.1 * off.max() and on.max() < 0.1 * inside_on


# ---------------------------------------------------------------------- gradient
def affine_compression(points, direction, e):
    """Shorten ``direction`` by the factor ``1 - e``, keep what is orthogonal to it."""
    d = np.asarray(direction) / np.linalg.norm(direction)
    return points - e * np.outer(points @ d, d)


def jittered(nx=21, size=40.0, amount=0.35, seed=0):
    """A flat irregular mesh: the grid's vertices moved at random in its plane."""
    s = grid(nx, nx, size)
    rng = np.random.default_rng(seed)
    step = size / (nx - 1)
    p = s.points + np.c_[amount * step * rng.uniform(-1, 1, (s.n_points, 2)),
                         np.zeros(s.n_points)]
    return s.with_points(p)


@pytest.mark.parametrize("irregular", [False, True])
@pytest.mark.parametrize(("e", "angle_deg"), [(0.05, 0.0), (0.2, 30.0), (0.4, 71.0)])
def test_gradient_is_exact_for_a_uniform_compression_where_eq10_is_not(irregular, e,
                                                                       angle_deg):
    skin = jittered() if irregular else grid(21, 21, 40.0)
    a = np.radians(angle_deg)
    d = np.array([np.cos(a), np.sin(a), 0.0])
    directions = np.tile(-d, (skin.n_points, 1))  # the sign does not matter
    moved = affine_compression(skin.points, d, e) + [3.0, -1.0, 2.0]
    eps = gradient_compression(skin.points, moved, skin.triangles, directions)
    np.testing.assert_allclose(eps, e, rtol=0, atol=1e-12)  # every vertex, boundary too
    interior = np.diff(skin.incidence.indptr) == 6
    edges = wv.compression(skin.points, moved, skin.edges, directions)[interior]
    assert np.abs(edges - e).min() > 0.1 * e  # Eq. 10 misses it at every interior vertex...
    assert edges.mean() < 0.9 * e  # ... low (two thirds for edges spread evenly in angle)
    if irregular:
        assert edges.max() - edges.min() > 0.2 * e  # ... and it depends on the edges


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_rigid_motion_compresses_nothing(seed):
    skin = jittered(seed=seed)
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(skin.n_points, 3))
    moved = skin.points @ rotation(seed).T + rng.normal(size=3) * 10
    eps = gradient_compression(skin.points, moved, skin.triangles, directions)
    np.testing.assert_allclose(eps, 0.0, atol=1e-12)


def random_deformation(points, seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(scale=0.01, size=(3, 3))
    k = rng.normal(scale=0.05, size=(3, 3))
    return points + points @ a.T + 2.0 * np.sin(points @ k.T)


@given(seed=st.integers(0, 2**16), rot_seed=st.integers(0, 2**16),
       shift=st.tuples(*[st.floats(-100, 100)] * 3), scale=st.floats(0.1, 10.0))
@settings(max_examples=40, deadline=None)
def test_gradient_eps_is_invariant_under_rigid_motion_and_uniform_scaling(seed, rot_seed,
                                                                          shift, scale):
    skin = jittered(15, seed=seed % 7)
    rest = skin.points + np.c_[np.zeros((skin.n_points, 2)), 0.01 * skin.points[:, 0] ** 2]
    moved = random_deformation(rest, seed)
    directions = np.random.default_rng(seed).normal(size=(skin.n_points, 3))
    rot = rotation(rot_seed)

    def place(p):
        return scale * p @ rot.T + np.asarray(shift)

    eps = gradient_compression(rest, moved, skin.triangles, directions)
    again = gradient_compression(place(rest), place(moved), skin.triangles,
                                 directions @ rot.T)
    np.testing.assert_allclose(again, eps, atol=1e-9)
    rigid = gradient_compression(rest, moved @ rot.T + np.asarray(shift), skin.triangles,
                                 directions)  # a rigid motion of the deformed skin only
    np.testing.assert_allclose(rigid, eps, atol=1e-9)


@given(rot_seed=st.integers(0, 2**16), shift=st.tuples(*[st.floats(-100, 100)] * 3),
       scale=st.floats(0.2, 5.0))
@settings(max_examples=8, deadline=None)
def test_a_faces_gradient_eps_is_invariant_under_rigid_motion_and_uniform_scaling(
        rot_seed, shift, scale):
    skin = grid(31, 31, 80.0, bump=8.0)
    muscles = [sheet(compression="gradient"), linear(compression="gradient", taper=True)]
    rot, shift = rotation(rot_seed), np.asarray(shift)

    def place(p):
        return scale * np.asarray(p).reshape(-1, 3) @ rot.T + shift

    # the geometric skin: the physical one has a length of its own, so it is not
    # invariant under scaling (tests/test_face.py)
    face0 = wv.FaceModel(skin, None, muscles, skin_model="geometric")
    face1 = wv.FaceModel(skin.with_points(place(skin.points)), None,
                         [m.transformed(place, scale) for m in muscles], skin_model="geometric")
    acts = {"sh": 0.8, "lin": 0.6}
    s0, s1 = face0.evaluate(acts), face1.evaluate(acts)
    for name in face0.muscle_names:
        assert np.isfinite(s0.fields[name]["eps"]).sum() > 20
        for key in ("eps", "A"):
            np.testing.assert_allclose(s1.fields[name][key], s0.fields[name][key],
                                       atol=1e-9, equal_nan=True)
    np.testing.assert_allclose(s1.W, scale * s0.W, atol=1e-9 * scale)


def test_a_faces_eps_A_and_W_follow_the_option(flat):
    """Driven by a sheet: the gradient gives the pull's analytic strain exactly."""
    grad, edges = sheet("grad", compression="gradient"), sheet("edges")
    face = wv.FaceModel(flat, None, [grad, edges, linear(compression="gradient")],
                        skin_model="geometric")  # the pull's own strain
    state = face.evaluate({"grad": 0.5, "edges": 0.5, "lin": 0.0})
    # the two sheets pull alike: together they compress by K m where the ramp is linear
    e, sigma = ramp_strain(grad)
    reg = grad.region(flat.points)
    affine = ((reg.l > sigma + H_STEP + 1e-9) & (reg.l < grad.fall_start_value - sigma
                                                 - H_STEP - 1e-9)
              & (reg.h < grad.attenuation_range[0] - H_STEP - 1e-9))
    assert affine.sum() > 100 and (affine & reg.in_region).sum() > 50
    g, ed = state.fields["grad"], state.fields["edges"]
    np.testing.assert_allclose(g["eps"][affine], e, rtol=0, atol=1e-12)
    assert np.all(np.abs(ed["eps"][affine] - e) > 0.15 * e)  # Eq. 10: about 0.78 e here
    rest, deformed = flat.points, state.deformed_points
    for name in face.muscle_names:
        m, f = face.muscle(name), state.fields[name]
        r = m.region(rest)
        directions = np.nan_to_num(r.direction)
        if m.compression == "gradient":
            expected = gradient_compression(rest, deformed, flat.triangles, directions)
        else:
            expected = wv.compression(rest, deformed, flat.edges, directions)
        np.testing.assert_array_equal(np.isfinite(f["eps"]), r.in_aoi)
        np.testing.assert_allclose(f["eps"][r.in_aoi], expected[r.in_aoi], atol=1e-12)
        np.testing.assert_allclose(f["A"], wv.anisotropy(f["eps"]), equal_nan=True)
        if state.activations[name] > 0:
            np.testing.assert_allclose(f["W"], f["H"] * f["A"] * f["At"], equal_nan=True,
                                       atol=1e-15)
    lin = state.fields["lin"]  # inactive: it reports its compression, makes no wrinkles
    assert np.nanmax(np.abs(lin["eps"])) > 0.05
    assert not np.nan_to_num(lin["W"]).any()
    total = np.nan_to_num(g["W"]) + np.nan_to_num(ed["W"])
    np.testing.assert_allclose(state.W, total, atol=1e-15)


def test_an_inactive_gradient_muscle_reports_its_compression(flat):
    face = wv.FaceModel(flat, None, [sheet("grad", compression="gradient"), sheet("edges")],
                        skin_model="geometric")  # the pull's own strain
    state = face.evaluate({"edges": 1.0})
    f = state.fields["grad"]
    reg = face.muscle("grad").region(flat.points)
    expected = gradient_compression(flat.points, state.deformed_points, flat.triangles,
                                    np.nan_to_num(reg.direction))
    np.testing.assert_allclose(f["eps"][reg.in_aoi], expected[reg.in_aoi], atol=1e-12)
    e, _ = ramp_strain(face.muscle("edges"))
    assert np.nanmax(f["eps"]) == pytest.approx(e, abs=1e-12)
    assert not np.nan_to_num(f["W"]).any() and np.isfinite(f["W"]).any()


def test_the_default_face_is_unchanged_by_the_options_code(flat):
    """Off, the frame takes no gradient work and gives Eq. 10 as before."""
    face = wv.FaceModel(flat, None, [sheet(), linear()])
    state = face.evaluate({"sh": 1.0, "lin": 0.7}, fold_guard=False)  # the pulls as such
    asm = face._assembly(("sh", "lin"))
    assert len(asm.g0) == 0 and asm.grad_op.shape[1] == 0
    for name in face.muscle_names:
        r = face.muscle(name).region(flat.points)
        eps = wv.compression(flat.points, state.deformed_points, flat.edges,
                             np.nan_to_num(r.direction))
        np.testing.assert_allclose(state.fields[name]["eps"][r.in_aoi], eps[r.in_aoi],
                                   atol=1e-12)


# ---------------------------------------------------------------------- layout files
def test_options_round_trip_through_layout_files_and_old_files_get_the_defaults(tmp_path):
    muscles = (linear(taper=True), sheet(compression="gradient"),
               ring(taper=True, compression="gradient"), sheet("plain"))
    layout = wv.Layout(name="options", muscles=muscles)
    path = tmp_path / "layout.json"
    wv.save_layout(layout, path)
    data = json.loads(path.read_text())
    assert [(m["taper"], m["compression"]) for m in data["muscles"]] == [
        (True, "edges"), (False, "gradient"), (True, "gradient"), (False, "edges")]
    assert list(data["muscles"][0])[-2:] == ["taper", "compression"]  # last in each muscle
    again = wv.load_layout(path)
    assert again == layout and again.muscles == muscles
    for m in data["muscles"]:  # a file written before the options existed
        del m["taper"], m["compression"]
    path.write_text(json.dumps(data))
    old = wv.load_layout(path)
    assert all(m.taper is False and m.compression == "edges" for m in old.muscles)
    assert old.muscles[3] == sheet("plain")
    data["muscles"][1]["compression"] = "cotangent"
    path.write_text(json.dumps(data))
    with pytest.raises(wv.LayoutError, match="compression"):
        wv.load_layout(path)


# ---------------------------------------------------------------------- the app
@pytest.mark.usefixtures("no_leaked_plotters")
@pytest.mark.parametrize("name", ["corrugator_L", "frontalis_major_L", "ring_1"])
def test_the_panel_switches_both_options_each_one_undo_step(window, name):
    if name == "ring_1":  # the plug-in type: its declared numbers and the options
        window.probe_vertex(int(np.argmax(window.session.face.skin.points[:, 2])))
        next(a for a in window.add_menu.actions() if a.text() == "ring").trigger()
    window.select_muscle(name)
    muscle = window.session.face.muscle(name)
    assert list(window.param_widgets) == [p.name for p in muscle.parameters() if p.is_number]
    window.activation_box.setValue(1.0)
    before = window.session.layout().to_dict()
    steps = window.undo_stack.count()
    box, combo = window.option_widgets["taper"], window.option_widgets["compression"]
    assert not box.isChecked()
    assert [combo.itemText(i) for i in range(combo.count())] == ["edges (Eq. 10)", "gradient"]
    assert combo.currentIndex() == 0
    h_before = window.session.state().fields[name]["H"].copy()

    box.click()
    assert window.session.face.muscle(name).taper is True
    assert window.undo_stack.count() == steps + 1
    assert window.undo_stack.undoText() == f"Set taper H at the ends of {name} to on"
    assert window.session.dirty and window.windowTitle().endswith("*")
    h_after = window.session.state().fields[name]["H"]
    assert not np.array_equal(np.nan_to_num(h_after), np.nan_to_num(h_before))
    eps_before = window.session.state().fields[name]["eps"].copy()

    combo.setCurrentIndex(1)
    assert window.session.face.muscle(name).compression == "gradient"
    assert window.undo_stack.count() == steps + 2
    assert window.undo_stack.undoText() == f"Set ε from of {name} to gradient"
    eps_after = window.session.state().fields[name]["eps"]
    assert not np.allclose(np.nan_to_num(eps_after), np.nan_to_num(eps_before))
    after = window.session.layout().to_dict()

    window.undo_stack.undo()
    box, combo = window.option_widgets["taper"], window.option_widgets["compression"]
    assert window.session.face.muscle(name).compression == "edges"
    assert combo.currentIndex() == 0 and box.isChecked()
    window.undo_stack.undo()
    assert window.session.face.muscle(name).taper is False and not box.isChecked()
    assert window.session.layout().to_dict() == before
    window.undo_stack.redo()
    window.undo_stack.redo()
    box, combo = window.option_widgets["taper"], window.option_widgets["compression"]
    assert box.isChecked() and combo.currentIndex() == 1
    assert window.session.layout().to_dict() == after
    assert window.undo_stack.count() == steps + 2  # syncing the panel made no edits
