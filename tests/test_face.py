import subprocess
import sys

import numpy as np
import pytest
from meshes import grid, rotation

import wrinkle_vis as wv

FIELDS = ("lambda", "gamma", "eps", "At", "H", "A", "W")


def muscles(shift=0.0, rot=None, scale=1.0):
    rot = np.eye(3) if rot is None else rot

    def p(x):
        return scale * np.asarray(x, float) @ rot.T + shift

    lin = wv.LinearMuscle("lin", p((-25, 0, -3)), p((5, 0, 1)), radius=scale * 40,
                          max_angle_deg=30, lambda_w=0.2, n_wrinkles=3, k0=scale * 1.0)
    sh = wv.SheetMuscle("sh", (p((-10, 5, -2)), p((-10, 25, -2))),
                        (p((15, 5, 1)), p((15, 25, 1))), lambda_w=0.3, n_wrinkles=2,
                        k0=scale * 0.5)
    return [lin, sh]


@pytest.fixture(scope="module")
def face():
    return wv.FaceModel(grid(61, 61, 80.0, bump=8.0), None, muscles())


def test_neutral_is_the_rest_skin(face):
    state = face.evaluate()
    np.testing.assert_array_equal(state.points, face.skin.points)
    assert not state.W.any()
    assert state.activations == {"lin": 0.0, "sh": 0.0}
    np.testing.assert_array_equal(state.fields["lin"]["W"][np.isfinite(
        state.fields["lin"]["W"])], 0.0)


def test_fields_follow_eq4_and_are_nan_where_undefined(face):
    state = face.evaluate({"lin": 0.8, "sh": 0.6})
    total = np.zeros(face.skin.n_points)
    for name in face.muscle_names:
        f = state.fields[name]
        reg = face.muscle(name).region(face.skin.points)
        for key in ("lambda", "gamma", "eps", "At", "A"):
            np.testing.assert_array_equal(np.isfinite(f[key]), reg.in_aoi)
        for key in ("H", "W"):
            np.testing.assert_array_equal(np.isfinite(f[key]), reg.in_region)
        np.testing.assert_allclose(f["H"], reg.H, equal_nan=True)
        np.testing.assert_allclose(f["At"][reg.in_aoi], reg.At[reg.in_aoi])
        np.testing.assert_allclose(f["A"], wv.anisotropy(f["eps"]), equal_nan=True)
        np.testing.assert_allclose(f["W"], f["H"] * f["A"] * f["At"], equal_nan=True)
        total += np.nan_to_num(f["W"])
        assert np.abs(f["W"][reg.in_region]).max() > 0
    np.testing.assert_allclose(state.W, total, atol=1e-15)


def test_eps_matches_the_public_compression_function(face):
    state = face.evaluate({"lin": 1.0})
    m = face.muscle("lin")
    reg = m.region(face.skin.points)
    eps = wv.compression(face.skin.points, state.deformed_points, face.skin.edges,
                         np.nan_to_num(reg.direction))
    np.testing.assert_allclose(state.fields["lin"]["eps"][reg.in_aoi], eps[reg.in_aoi],
                               atol=1e-12)


def test_deformation_and_final_points(face):
    """The summed pull made tangent, bent back by the second fundamental form, plus W (the
    geometric skin's deformation).
    """
    from wrinkle_vis.core.face import SLIDE_SCALE
    from wrinkle_vis.core.mesh import shape_operators, smoothed_normals

    state = face.evaluate({"lin": 0.5, "sh": 1.0}, skin="geometric")
    rest = face.skin.points
    radius = SLIDE_SCALE * np.sqrt(face.skin.triangle_areas().sum())
    n = smoothed_normals(face.skin, face.skin.vertex_normals(), radius)
    pull = sum(m.displacement(rest, state.activations[m.name]) for m in face.muscles)
    pull -= np.einsum("ij,ij->i", pull, n)[:, None] * n
    beta = 0.5 * np.einsum("ij,ijk,ik->i", pull, shape_operators(face.skin, n), pull)
    reach = 0.3 * np.linalg.norm(pull, axis=1)
    bend = beta / np.sqrt(1.0 + (beta / np.maximum(reach, 1e-300)) ** 2)
    expected = rest + pull - bend[:, None] * n
    np.testing.assert_allclose(state.deformed_points, expected, atol=1e-12)
    normals = face.skin.vertex_normals(state.deformed_points)
    np.testing.assert_allclose(state.points, expected + state.W[:, None] * normals, atol=1e-12)
    assert np.all(normals[state.W != 0][:, 2] > 0.5)  # outward (+z on this dome)


def test_inactive_muscle_reports_compression_but_makes_no_wrinkles(face):
    state = face.evaluate({"lin": 1.0})
    f = state.fields["sh"]
    assert np.isfinite(f["eps"]).any()
    w = f["W"][np.isfinite(f["W"])]
    assert len(w) and not w.any()


def test_intensity_and_expressions():
    f = wv.FaceModel(grid(21, 21, 80.0), None, muscles(),
                     {"both": wv.Expression("both", {"lin": 1.0, "sh": 0.5})})
    assert f.evaluate("both", intensity=0.5).activations == {"lin": 0.5, "sh": 0.25}
    np.testing.assert_array_equal(f.evaluate("both", 0.5).points,
                                  f.evaluate({"lin": 0.5, "sh": 0.25}).points)


def test_a_renamed_muscle_is_renamed_in_place_in_every_expression():
    f = wv.FaceModel(grid(21, 21, 80.0), None, muscles(),
                     {"both": wv.Expression("both", {"lin": 1.0, "sh": 0.5}),
                      "sheet": wv.Expression("sheet", {"sh": 0.7})})
    g = f.with_muscle(f.muscle("lin").replace(name="line"), replacing="lin")
    assert g.muscle_names == ("line", "sh")
    assert list(g.expressions["both"].activations.items()) == [("line", 1.0), ("sh", 0.5)]
    assert g.expressions["sheet"] is f.expressions["sheet"]  # untouched: the same object
    h = g.without_muscle("line")
    assert dict(h.expressions["both"].activations) == {"sh": 0.5}


@pytest.mark.parametrize(
    ("activations", "error", "message"),
    [
        ({"nope": 1.0}, KeyError, "no muscle named 'nope'.*lin, sh"),
        ({"lin": 1.5}, ValueError, "'lin'.*outside"),
        ({"lin": float("nan")}, ValueError, "'lin'"),
        ({"lin": "a lot"}, ValueError, "'lin'"),
        ("laughing", KeyError, "unknown expression 'laughing'"),
        (3, TypeError, "expression name"),
    ],
)
def test_bad_activations(face, activations, error, message):
    with pytest.raises(error, match=message):
        face.evaluate(activations)


def test_bad_intensity(face):
    with pytest.raises(ValueError, match="intensity"):
        face.evaluate({"lin": 1.0}, intensity=2.0)


def test_bad_faces():
    skin = grid(5, 5)
    with pytest.raises(ValueError, match="two muscles are named 'lin'"):
        wv.FaceModel(skin, None, [muscles()[0], muscles()[0]])
    with pytest.raises(TypeError, match="TriangleSurface"):
        wv.FaceModel(skin.points, None, [])
    seam = wv.TriangleSurface(np.r_[skin.points, skin.points[:1]],
                              np.r_[skin.triangles, [[0, 1, 25]]])
    with pytest.raises(wv.MeshError, match="zero length.*welded"):
        wv.FaceModel(seam, None, [])
    dup = wv.TriangleSurface(skin.points, np.r_[skin.triangles, skin.triangles[:2]])
    with pytest.raises(wv.MeshError, match="duplicate.*cleaned"):
        wv.FaceModel(dup, None, [])


def test_rest_data_is_cached_and_shared_by_derived_faces(face):
    lin = face.muscle("lin")
    data = face.muscle_data(lin)
    face.evaluate({"lin": 1.0})
    assert face.muscle_data(lin) is data
    changed = face.with_muscle(lin.replace(k0=2.0))
    assert changed.muscle_data(changed.muscle("sh")) is face.muscle_data(face.muscle("sh"))
    assert changed.muscle_data(changed.muscle("lin")) is not data
    w1 = changed.evaluate({"lin": 1.0}).fields["lin"]["W"]
    w0 = face.evaluate({"lin": 1.0}).fields["lin"]["W"]
    np.testing.assert_allclose(w1, 2 * w0, equal_nan=True)
    assert face.without_muscle("sh").muscle_names == ("lin",)


def test_state_arrays_are_read_only(face):
    state = face.evaluate({"lin": 1.0})
    for arr in (state.points, state.W, state.fields["lin"]["W"]):
        with pytest.raises(ValueError):
            arr[0] = 1.0


@pytest.mark.parametrize("seed", [3, 4])
def test_every_field_is_invariant_under_rigid_motion(seed):
    skin = grid(41, 41, 80.0, bump=8.0)
    rot, shift = rotation(seed), np.array([12.0, -40.0, 7.0])
    face0 = wv.FaceModel(skin, None, muscles())
    face1 = wv.FaceModel(skin.with_points(skin.points @ rot.T + shift), None,
                         muscles(shift, rot))
    acts = {"lin": 0.9, "sh": 0.7}
    s0, s1 = face0.evaluate(acts), face1.evaluate(acts)
    for name in face0.muscle_names:
        for key in FIELDS:
            np.testing.assert_allclose(s1.fields[name][key], s0.fields[name][key], atol=1e-9,
                                       equal_nan=True)
    np.testing.assert_allclose(s1.W, s0.W, atol=1e-9)
    np.testing.assert_allclose(s1.points, s0.points @ rot.T + shift, atol=1e-9)


def test_lambda_gamma_eps_are_invariant_under_uniform_scaling():
    """On the geometric skin (the physical one has a length of its own, the square root of
    its membrane over its attachment stiffness, so a face three times as big deforms
    otherwise there: by design).
    """
    skin = grid(41, 41, 80.0, bump=8.0)
    face0 = wv.FaceModel(skin, None, muscles(), skin_model="geometric")
    face1 = wv.FaceModel(skin.with_points(3.0 * skin.points), None, muscles(scale=3.0),
                         skin_model="geometric")
    s0, s1 = face0.evaluate({"lin": 1.0, "sh": 1.0}), face1.evaluate({"lin": 1.0, "sh": 1.0})
    for name in face0.muscle_names:
        for key in ("lambda", "gamma", "eps"):
            np.testing.assert_allclose(s1.fields[name][key], s0.fields[name][key], atol=1e-9,
                                       equal_nan=True)
    np.testing.assert_allclose(s1.W, 3.0 * s0.W, atol=1e-9)


def test_expression_ramp():
    ex = wv.Expression("e", {"a": 0.8}, onset_s=1.0, hold_s=2.0, release_s=1.0)
    assert ex.duration_s == 4.0
    assert ex.at(-1.0) == {"a": 0.0} and ex.at(0.0) == {"a": 0.0}
    assert ex.at(0.5)["a"] == pytest.approx(0.4)
    assert ex.at(1.0) == ex.at(2.5) == {"a": 0.8}
    assert ex.at(3.5)["a"] == pytest.approx(0.4)
    assert ex.at(4.0)["a"] == pytest.approx(0.0) and ex.at(9.0) == {"a": 0.0}
    times = np.linspace(0, 1, 50)
    assert np.all(np.diff([ex.at(t)["a"] for t in times]) >= 0)
    assert ex.at(1.5, intensity=0.5) == {"a": 0.4}
    assert wv.Expression.from_dict(ex.to_dict()) == ex
    with pytest.raises(ValueError, match="'e'.*outside"):
        wv.Expression("e", {"a": 1.2})
    with pytest.raises(ValueError, match="onset_s"):
        wv.Expression("e", {}, onset_s=-1)


def test_paper_expressions_use_the_muscles_section_3_names():
    ex = wv.paper_expressions()
    assert set(ex) == {"neutral", "surprise", "frown", "fear"}
    assert set(ex["surprise"].activations) == {
        f"frontalis_{p}_{s}" for p in ("major", "inner", "outer") for s in "LR"}
    assert set(ex["frown"].activations) == {"corrugator_L", "corrugator_R"}
    assert set(ex["fear"].activations) == {"frontalis_inner_L", "frontalis_inner_R",
                                           "corrugator_L", "corrugator_R"}


def test_core_imports_no_vtk_pyvista_or_qt():
    code = ("import sys, wrinkle_vis, wrinkle_vis.core; "
            "bad = [m for m in ('vtk', 'vtkmodules', 'pyvista', 'qtpy', 'PySide6', 'pyvistaqt',"
            " 'wrinkle_vis.plotting')"
            " if m in sys.modules]; print(bad); sys.exit(1 if bad else 0)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def test_core_sources_import_only_the_standard_library_numpy_and_scipy():
    """Not even inside a function: the import contract declares no exception
    (pyproject.toml's ``ignore_imports``; the plot methods are bound from
    ``wrinkle_vis/_plot.py``).
    """
    import ast
    import pathlib
    import tomllib

    root = pathlib.Path(wv.core.__file__).parent
    allowed = set(sys.stdlib_module_names) | {"numpy", "scipy"}
    config = tomllib.loads((root.parents[1] / "pyproject.toml").read_text())
    declared = {tuple(s.split(" -> ")) for c in config["tool"]["importlinter"]["contracts"]
                for s in c.get("ignore_imports", []) if s.startswith("wrinkle_vis.core")}
    assert declared == set()
    seen = set()
    for path in root.glob("*.py"):
        tree = ast.parse(path.read_text())
        top = {id(n) for n in tree.body}
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module]
            elif isinstance(node, ast.ImportFrom):
                assert node.level == 1, (path, node.module)  # nothing above core
            for n in names:
                if n.split(".")[0] in allowed:
                    continue
                pair = (f"wrinkle_vis.core.{path.stem}", n)
                assert pair in declared and id(node) not in top, (path, n)  # lazy, declared
                seen.add(pair)
    assert seen == declared  # the declaration is not stale


def test_states_are_freed_without_the_garbage_collector(face):
    import gc
    import weakref

    gc.disable()
    try:
        state = face.evaluate({"lin": 1.0})
        fields = state.fields["lin"]
        ref = weakref.ref(state)
        del state
        assert ref() is None
        assert np.isfinite(fields["eps"]).any()  # views outlive their state
    finally:
        gc.enable()


def test_the_skin_slides_along_a_sphere_instead_of_cutting_through_it():
    """A 6 mm pull on a sphere of radius 50 mm: the straight pull leaves the sphere by about
    |D|^2 / (2 rho) = 0.36 mm; the sliding skin stays on it to third order in |D| / rho.
    """
    from meshes import sphere

    rho = 50.0
    skin = sphere(5, rho)
    sh = wv.SheetMuscle("sh", ((-20, 30, 40), (20, 30, 40)), ((-20, 0, 50), (20, 0, 50)),
                        length=45.0, width=60.0, depth=40.0, fall_start=30.0, strength=6.0,
                        lambda_w=0.3, n_wrinkles=2, k0=0.0)
    state = wv.FaceModel(skin, None, [sh]).evaluate({"sh": 1.0})
    moved = np.linalg.norm(state.deformed_points - skin.points, axis=1)
    assert moved.max() > 5.0
    straight = skin.points + sh.displacement(skin.points, 1.0)
    off_straight = np.abs(np.linalg.norm(straight, axis=1) - rho)
    off_sliding = np.abs(np.linalg.norm(state.deformed_points, axis=1) - rho)
    assert off_straight.max() > 0.2
    assert off_sliding.max() < 0.15 * off_straight.max()
