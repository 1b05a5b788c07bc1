import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from meshes import assert_c1_along_random_lines, grid, rotation

import wrinkle_vis as wv


def linear(attachment=(0, 0, 0), insertion=(10, 0, 0), **kw):
    args = dict(radius=20.0, max_angle_deg=45.0, lambda_w=0.25, n_wrinkles=3, k0=1.0,
                alpha=1.0)
    return wv.LinearMuscle("lin", attachment, insertion, **{**args, **kw})


def sheet(**kw):
    args = dict(lambda_w=0.2, n_wrinkles=3, k0=1.0, alpha=1.0)
    args.update(kw)
    return wv.SheetMuscle("sh", ((0, -10, 0), (0, 10, 0)), ((20, -10, 0), (20, 10, 0)), **args)


def sphincter(**kw):
    from wrinkle_vis.core.sphincter import SphincterMuscle

    args = dict(lambda_w=0.4, n_wrinkles=4, k0=1.0, alpha=1.0, sector_deg=60.0, depth=8.0)
    args.update(kw)
    return SphincterMuscle("sp", (8, 8, 0), (28, 8, 0), (8, 22, 0), **args)


def test_linear_hand_computed_points():
    m = linear()
    pts = np.array([[10, 10, 0], [5, 0, 0], [-5, 1, 0], [10, 10 * np.tan(np.radians(30)), 0],
                    [0, 0, 19.0]])
    r = m.region(pts)
    np.testing.assert_allclose(r.angle_deg, [45, 0, 180 - np.degrees(np.arctan(1 / 5)), 30, 90])
    np.testing.assert_allclose(r.l, [10, 5, -5, 10, 0], atol=1e-12)
    np.testing.assert_allclose(r.lam, [0.5, 0.25, -0.25, 0.5, 0], atol=1e-12)
    np.testing.assert_allclose(r.gamma[[0, 1, 3]], [1.0, 0.0, 2 / 3])
    np.testing.assert_array_equal(r.in_aoi, [True, True, False, True, False])
    np.testing.assert_array_equal(r.in_region, [True, True, False, True, False])
    # direction at x is unit(m_A - x)
    np.testing.assert_allclose(r.direction[1], [-1, 0, 0])
    assert np.isnan(r.direction[2]).all() and np.isnan(r.H[2])
    # At: 1 up to phi_c = 22.5 deg, cubic to 0 at 45
    s = (30 - 22.5) / 22.5
    assert r.At[3] == pytest.approx(-0.5 * (1 + s * s) * s + 1)
    assert r.At[1] == 1.0 and r.At[0] == pytest.approx(0.0)
    # w and H: u = (1 - 0.25) 20 / 6 = 2.5; l = 10 -> w = (10 - 5) mod 5 = 0
    assert m.u == pytest.approx(2.5)
    assert r.w[0] == pytest.approx(0.0) and r.w[1] == pytest.approx(0.0)
    assert r.H[0] == pytest.approx(m.d - m.k0 * 2**m.alpha)


def test_sheet_hand_computed_points():
    m = sheet()
    f, s, n = m.frame
    np.testing.assert_allclose([f, s, n], np.eye(3), atol=1e-12)
    assert (m.length_value, m.width_value, m.depth_value) == (25.0, 20.0, 12.5)
    pts = np.array([[10, 5, 3], [10, -5, 13], [10, 9, 0], [30, 0, 0], [5, -10, 0]])
    r = m.region(pts)
    np.testing.assert_allclose(r.l, [10, 10, 10, 30, 5])
    np.testing.assert_allclose(r.h, [5, 5, 9, 0, 10])
    np.testing.assert_allclose(r.lam, [0.4, 0.4, 0.4, 1.2, 0.2])
    np.testing.assert_allclose(r.gamma, [0.5, 0.5, 0.9, 0, 1.0])
    np.testing.assert_array_equal(r.in_aoi, [True, False, True, False, True])
    np.testing.assert_array_equal(r.in_region, [True, False, True, False, True])
    np.testing.assert_allclose(r.direction[0], [-1, 0, 0])
    # Eq. 15 with h_c = W_s / 4 = 5 and W_s / 2 = 10
    assert r.At[0] == 1.0
    s_ = (9 - 5) / 5
    assert r.At[2] == pytest.approx(-0.5 * (1 + s_**2) * s_ + 1)


def test_displacement_is_linear_in_activation_and_zero_outside_aoi():
    m = linear()
    pts = np.random.default_rng(1).uniform(-25, 25, size=(500, 3))
    d1 = m.displacement(pts, 1.0)
    np.testing.assert_allclose(m.displacement(pts, 0.3), 0.3 * d1)
    outside = ~m.region(pts).in_aoi
    assert np.all(d1[outside] == 0)
    # pulls towards the attachment, never past it
    towards = np.einsum("ij,ij->i", d1, -pts)
    assert np.all(towards >= -1e-12)
    assert np.all(np.linalg.norm(d1, axis=1) < np.linalg.norm(pts, axis=1) + 1e-12)


def test_waters_radial_profile():
    # Waters' sin/cos profile squared: the same rise and fall, zero slope at 0, R_s, R_f
    x = np.array([-1, 0, 5, 10, 15, 20, 25.0])
    np.testing.assert_allclose(wv.waters_radial(x, 10, 20),
                               [0, 0, np.sin(np.pi / 4) ** 2, 1, np.cos(np.pi / 4) ** 2, 0, 0],
                               atol=1e-15)


def _max_slope_jump(f, knots, h=1e-6):
    """Largest difference between the one-sided slopes of ``f`` at ``knots``."""
    k = np.asarray(knots, float)
    left = (f(k) - f(k - h)) / h
    right = (f(k + h) - f(k)) / h
    return np.max(np.abs(right - left))


def test_builtin_falloffs_are_c1_at_every_knot():
    from wrinkle_vis.core.muscle import plateau_fall, smooth_fall

    assert _max_slope_jump(lambda x: wv.waters_radial(x, 10, 20), [0, 10, 20]) < 1e-5
    assert _max_slope_jump(lambda x: plateau_fall(x, 3, 8), [-8, -3, 0, 3, 8]) < 1e-5
    assert _max_slope_jump(smooth_fall, [0, 1]) < 1e-5
    t = np.linspace(0, 1, 11)  # two facing falls add up to one: sheets join without a seam
    np.testing.assert_allclose(smooth_fall(t) + smooth_fall(1 - t), 1.0, atol=1e-15)


@pytest.mark.parametrize("kind", ["linear", "sheet", "sphincter"])
def test_muscle_displacement_is_c1_across_the_aoi_boundary(kind):
    """Along lines through the muscle, the displacement's slope does not jump anywhere."""
    m = {"linear": linear, "sheet": sheet, "sphincter": sphincter}[kind]()
    assert_c1_along_random_lines(m)


def test_sheet_displacement_is_along_the_fibre_and_continuous_at_the_aoi_edge():
    m = sheet()
    pts = np.array([[10, 0, 0], [25, 0, 0], [10, 10, 0], [0, 0, 0]])
    d = m.displacement(pts, 1.0)
    assert d[0, 0] < 0 and np.allclose(d[0, 1:], 0)
    np.testing.assert_allclose(d[1:], 0, atol=1e-12)


BAD_LINEAR = [
    (dict(insertion=(0, 0, 0)), "insertion", "zero-length"),
    (dict(radius=-1.0), "radius", "(0, inf)"),
    (dict(radius=5.0), "radius", "inside the area of influence"),
    (dict(radius=math.nan), "radius", "nan"),
    (dict(max_angle_deg=0.0), "max_angle_deg", "(0, 90]"),
    (dict(max_angle_deg=120.0), "max_angle_deg", "(0, 90]"),
    (dict(lambda_w=1.0), "lambda_w", "[0, 1)"),
    (dict(lambda_w=-0.1), "lambda_w", "[0, 1)"),
    (dict(n_wrinkles=0), "n_wrinkles", "integer >= 1"),
    (dict(n_wrinkles=2.5), "n_wrinkles", "integer >= 1"),
    (dict(k0=-1.0), "k0", "[0, inf)"),
    (dict(alpha=-2.0), "alpha", "[-1, 10]"),
    (dict(attenuation_start_deg=50.0), "attenuation_start_deg", "[0, 45]"),
    (dict(fall_start=25.0), "fall_start", "(0, 20)"),
    (dict(strength=10.0), "strength", "past the attachment"),
    (dict(attachment=(0, np.nan, 0)), "attachment", "finite"),
    (dict(insertion=(1, 2)), "insertion", "shape (3,)"),
]


BAD_SHEET = [
    (dict(length=0.0), "length", "(0, inf)"),
    (dict(length=15.0), "length", "inside the AOI"),
    (dict(width=-3.0), "width", "(0, inf)"),
    (dict(depth=0.0), "depth", "(0, inf)"),
    (dict(attenuation_start=11.0), "attenuation_start", "[0, 10]"),
    (dict(fall_start=30.0), "fall_start", "(0, 25)"),
    (dict(alpha=11.0), "alpha", "[-1, 10]"),
]


@pytest.mark.parametrize(
    ("make", "name", "changes", "param", "fragment"),
    [(linear, "lin", *case) for case in BAD_LINEAR] + [(sheet, "sh", *case) for case in BAD_SHEET],
)
def test_bad_parameters_name_muscle_parameter_value_and_range(make, name, changes, param,
                                                              fragment):
    with pytest.raises(wv.MuscleParameterError) as info:
        make(**changes)
    msg = str(info.value)
    assert f"'{name}'" in msg and f"parameter {param} =" in msg and fragment in msg
    assert info.value.param == param


def test_bad_sheet_lines():
    with pytest.raises(wv.MuscleParameterError, match="zero-length attachment line"):
        wv.SheetMuscle("s", ((0, 0, 0), (0, 0, 0)), ((1, 0, 0), (1, 1, 0)))
    with pytest.raises(wv.MuscleParameterError, match="zero-length muscle"):
        wv.SheetMuscle("s", ((0, 0, 0), (0, 2, 0)), ((0, 2, 0), (0, 0, 0)))
    with pytest.raises(wv.MuscleParameterError, match="not parallel"):
        wv.SheetMuscle("s", ((0, 0, 0), (1, 0, 0)), ((5, 0, 0), (6, 0, 0)))
    with pytest.raises(wv.MuscleParameterError, match="non-empty string"):
        wv.SheetMuscle("", ((0, 0, 0), (0, 1, 0)), ((5, 0, 0), (5, 1, 0)))


def test_muscles_are_immutable_and_hashable():
    m = linear()
    with pytest.raises(AttributeError):
        m.radius = 3.0
    assert hash(m) == hash(linear()) and m == linear()
    assert m.replace(k0=2.0).k0 == 2.0 and m.k0 == 1.0
    with pytest.raises(wv.MuscleParameterError):
        m.replace(k0=-2.0)


def test_activation_must_be_in_unit_interval():
    with pytest.raises(ValueError, match="'lin'.*outside"):
        linear().displacement(np.zeros((1, 3)), 1.5)


finite = st.floats(-50, 50, allow_nan=False)


@given(ax=finite, ay=finite, ix=finite, iy=finite, iz=st.floats(1, 30),
       extra=st.floats(1.01, 3.0), phi=st.floats(1, 90), lw=st.floats(0, 0.95),
       nw=st.integers(1, 8), k0=st.floats(0, 5), alpha=st.floats(-1, 10))
@settings(max_examples=60)
def test_linear_round_trips_through_a_dict(ax, ay, ix, iy, iz, extra, phi, lw, nw, k0, alpha):
    length = math.dist((ax, ay, 0), (ix, iy, iz))
    m = wv.LinearMuscle("m", (ax, ay, 0), (ix, iy, iz), radius=extra * length,
                        max_angle_deg=phi, lambda_w=lw, n_wrinkles=nw, k0=k0, alpha=alpha)
    d = m.to_dict()
    assert d["type"] == "linear"
    assert wv.muscle_from_dict(d) == m
    import json
    assert wv.muscle_from_dict(json.loads(json.dumps(d))) == m


def test_sheet_round_trips_and_unknown_keys_fail():
    m = sheet(width=18.0, attenuation_start=2.0)
    assert wv.muscle_from_dict(m.to_dict()) == m
    bad = m.to_dict() | {"colour": "red"}
    with pytest.raises(wv.MuscleParameterError, match="unknown parameter.*colour"):
        wv.muscle_from_dict(bad)
    missing = {k: v for k, v in m.to_dict().items() if k != "insertion_line"}
    with pytest.raises(wv.MuscleParameterError, match="missing.*insertion_line"):
        wv.muscle_from_dict(missing)


def _moved(m, rot, shift, scale=1.0):
    changes = {}
    for p in m.point_parameters:
        arr = np.asarray(getattr(m, p))
        changes[p] = scale * arr @ rot.T + shift
    fields = {f.name for f in dataclasses.fields(m)}
    for p in ("radius", "length", "width", "depth", "fall_start", "strength", "k0",
              "attenuation_start"):
        if p in fields and getattr(m, p) is not None:
            changes[p] = scale * getattr(m, p)
    return m.replace(**changes)


@pytest.mark.parametrize("make", [linear, sheet, sphincter])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_region_is_invariant_under_rigid_motion_and_lambda_gamma_under_scaling(make, seed):
    m = make()
    pts = np.random.default_rng(seed).uniform(-5, 25, size=(400, 3))
    rot, shift = rotation(seed), np.array([3.0, -7.0, 11.0])
    r0 = m.region(pts)
    r1 = _moved(m, rot, shift).region(pts @ rot.T + shift)
    for key in ("lam", "gamma", "l", "w", "H", "At"):
        np.testing.assert_allclose(r1[key], r0[key], atol=1e-9, equal_nan=True)
    np.testing.assert_array_equal(r1.in_aoi, r0.in_aoi)
    np.testing.assert_allclose(r1.direction, r0.direction @ rot.T, atol=1e-9)
    r2 = _moved(m, np.eye(3), 0.0, scale=2.5).region(2.5 * pts)
    for key in ("lam", "gamma"):
        np.testing.assert_allclose(r2[key], r0[key], atol=1e-9)


def _plates(hidden: bool) -> wv.TriangleSurface:
    """A 100 mm square "forehead" facing +z at z = 0 and, with ``hidden``, a "socket roof"
    25 mm behind it facing away (-z), as on a scan with open eye sockets."""
    front = grid(41, 41, 100.0)
    if not hidden:
        return front
    back = front.points + [0.0, 0.0, -25.0]
    tris = front.triangles[:, ::-1] + front.n_points  # facing -z
    return wv.TriangleSurface(np.r_[front.points, back], np.r_[front.triangles, tris])


def _forehead_face(skin, skin_model="geometric"):
    sheet = wv.SheetMuscle("frontalis", [[-15.0, 40.0, 0.0], [15.0, 40.0, 0.0]],
                           [[-15.0, -10.0, 0.0], [15.0, -10.0, 0.0]], lambda_w=0.2,
                           n_wrinkles=3, k0=1.0, alpha=1.0)
    assert sheet.depth_value > 25.0  # its prism takes in the plate behind
    return wv.FaceModel(skin, None, [sheet], {"up": wv.Expression("up", {"frontalis": 1.0})},
                        skin_model=skin_model)


@pytest.mark.parametrize("refine", [False, True])
def test_a_sheet_leaves_out_the_skin_behind_the_skin_it_wrinkles(refine):
    """Issue 32: a sheet's AOI, a prism through everything in its depth bound, reached skin
    behind the forehead (the roof of a scan's eye socket, 25 mm back) and wrinkled it more
    than the forehead. That skin gets no AOI and no W, and the forehead's frame is the one
    it has without the skin behind it, to the last bit (on the geometric skin; the physical
    skin solves both plates in one linear system, whose rounding differs in the last bits:
    there to 1e-12 of the W range)."""
    alone = _forehead_face(_plates(hidden=False)).evaluate("up", refine=refine)
    both = _forehead_face(_plates(hidden=True)).evaluate("up", refine=refine)
    front = both.rest_points[:, 2] > -1.0
    assert np.abs(alone.W).max() > 0.1
    np.testing.assert_array_equal(both.W[front], alone.W)
    np.testing.assert_array_equal(both.points[front], alone.points)
    assert not np.any(both.W[~front]) and np.array_equal(both.points[~front],
                                                         both.rest_points[~front])
    assert np.isnan(both.fields["frontalis"]["lambda"][~front]).all()
    alone, both = (_forehead_face(_plates(hidden=h), "physical").evaluate("up", refine=refine)
                   for h in (False, True))
    front = both.rest_points[:, 2] > -1.0
    assert not np.any(both.W[~front])
    np.testing.assert_allclose(both.W[front], alone.W, rtol=0, atol=1e-12 * np.ptp(alone.W))
