import json
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.datasets import read_surface, transfer_layout
from wrinkle_vis.plotting import to_surface_polydata

REAL = Path(__file__).resolve().parents[2] / "shared" / "realmeshes"
HEAD = REAL / "lee_perry_smith_head.obj"
EXAMPLE = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"

needs_scans = pytest.mark.skipif(not HEAD.exists(), reason="../shared/realmeshes is not here")


@needs_scans
def test_head_scan_loads_as_it_is_and_welds_its_uv_seams():
    raw = pv.read(HEAD)
    assert raw.n_points > 30000  # the reader splits vertices along UV seams
    skin = read_surface(HEAD)
    rep = skin.report()
    assert skin.n_points == 8844 and rep.n_components == 1
    assert len(rep.non_manifold_edges) == 0 and rep.consistently_oriented


@needs_scans
@pytest.mark.parametrize("name", ["skull_low_resolution.obj", "demosthenes_bust.obj"])
def test_other_scans_load_and_report_boundaries(name):
    s = read_surface(REAL / name)
    rep = s.report()
    assert rep.n_components == 1
    if name.startswith("demosthenes"):
        assert len(rep.boundary_edges) > 0  # open at the base: reported, not an error


@needs_scans
def test_example_layout_evaluates_on_the_scan(example_scan):
    face = example_scan.with_skin_model(example_scan.skin_model)  # (conftest)
    assert len(face.muscles) == 17  # the example layout (written before the AU muscles)
    for expression in ("surprise", "frown", "fear"):
        state = face.evaluate(expression)
        assert np.count_nonzero(state.W) > 0
        # wrinkles above the nose tip only, on this +y-up scan
        nose_y = face.muscle("corrugator_L").insertion[1] - 0.05
        assert face.skin.points[state.W != 0][:, 1].min() > nose_y


@needs_scans
def test_transfer_puts_insertions_on_the_skin_and_attachments_on_the_skull():
    layout = wv.load_layout(EXAMPLE)
    skin = read_surface(HEAD)
    landmarks = layout.landmarks
    face = wv.datasets.load_face(skin=skin, landmarks=landmarks, unit="m")  # layout moved
    moved = transfer_layout(wv.load_layout(wv.datasets.BUILTIN_LAYOUT), skin, landmarks,
                            face.skull)
    for m in moved.muscles:
        for p in [p for p in m.point_parameters if np.ndim(getattr(m, p)) == 1]:
            pts = np.asarray(getattr(m, p)).reshape(-1, 3)
            surf = face.skull if m.point_surfaces()[p] == "skull" else skin
            assert np.abs(closest_points(surf, pts) - pts).max() < 1e-9
    # lengths scale by about mm -> m (a radius also with its muscle's new length)
    builtin = wv.load_layout(wv.datasets.BUILTIN_LAYOUT)
    ratio = moved.muscles[0].width / builtin.muscles[0].width
    assert 0.0008 < ratio < 0.0012
    for m, b in zip(moved.muscles, builtin.muscles, strict=True):
        if m.type_name == "linear":
            ratio = (m.radius / np.linalg.norm(np.subtract(m.insertion, m.attachment))
                     / (b.radius / np.linalg.norm(np.subtract(b.insertion, b.attachment))))
            assert ratio == pytest.approx(1.0)
    # the skull lies under the skin by the regional depth (about 4-25 mm here)
    gap = np.linalg.norm(closest_points(skin, face.skull.points[::40]) - face.skull.points[::40],
                         axis=1)
    assert 0.002 < np.median(gap) < 0.015


def test_transfer_needs_shared_landmarks():
    layout = wv.load_layout(wv.datasets.BUILTIN_LAYOUT)
    face = wv.datasets.load_face()
    with pytest.raises(ValueError, match="at least 4 landmarks"):
        transfer_layout(layout, face.skin, {"nose_tip": [0, 0, 0], "elbow": [1, 1, 1]})


def test_transfer_onto_a_moved_copy_of_the_builtin_face_moves_the_muscles_with_it():
    face = wv.datasets.load_face()
    layout = wv.load_layout(wv.datasets.BUILTIN_LAYOUT)
    rot = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])

    def move(p):
        return 2.0 * np.asarray(p) @ rot.T + [5.0, 6.0, 7.0]

    skin = face.skin.with_points(move(face.skin.points))
    skull = face.skull.with_points(move(face.skull.points))
    marks = {k: move(v) for k, v in layout.landmarks.items()}
    moved = transfer_layout(layout, skin, marks, skull)
    for a, b in zip(layout.muscles, moved.muscles, strict=True):
        for p in a.point_parameters:
            if np.ndim(getattr(a, p)) > 1:  # a sheet's frame lines are moved exactly
                np.testing.assert_allclose(getattr(b, p), move(getattr(a, p)), atol=1e-9)
            else:  # points are projected onto the moved (remeshed) surfaces
                np.testing.assert_allclose(getattr(b, p), move(getattr(a, p)), atol=1.5)
    assert moved.muscles[0].k0 == pytest.approx(2 * layout.muscles[0].k0)


def test_a_scan_without_layout_or_landmarks_gets_no_muscles(tmp_path):
    face = wv.datasets.load_face()
    path = tmp_path / "face.ply"
    to_surface_polydata(face.skin).save(path)
    with pytest.warns(wv.core.units.UnitWarning, match="reads as mm"):
        plain = wv.datasets.load_face(skin=path)
    assert plain.muscles == () and set(plain.expressions) == {"neutral"}
    assert plain.unit == "mm"
    rep = plain.skull.report()  # a closed skull, 2.5 % of the height inside
    assert len(rep.boundary_edges) == 0 and len(rep.non_manifold_edges) == 0
    assert 0 < plain.skull.signed_volume()
    assert not plain.evaluate().W.any()
    quiet = wv.datasets.load_face(skin=path, unit="mm")  # a unit given: no warning
    assert quiet.unit == "mm"


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".vtp", ".vtk"])
def test_every_format_reads_back(tmp_path, suffix):
    skin = wv.datasets.load_face().skin
    path = tmp_path / f"skin{suffix}"
    poly = to_surface_polydata(skin)
    if suffix == ".obj":
        pl = pv.Plotter(off_screen=True)
        pl.add_mesh(poly)
        pl.export_obj(path)
        pl.close()
    else:
        poly.save(path)
    back = read_surface(path, weld_tolerance=1e-6)
    assert back.n_points == skin.n_points and back.n_triangles == skin.n_triangles


def test_bad_mesh_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="no mesh file at"):
        read_surface(tmp_path / "missing.obj")
    junk = tmp_path / "junk.xyz123"
    junk.write_text("not a mesh")
    with pytest.raises(wv.MeshError, match="junk.xyz123"):
        read_surface(junk)
    nan = tmp_path / "nan.obj"
    nan.write_text("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(wv.MeshError, match="nan.obj.*non-finite"):
        read_surface(nan)
    empty = tmp_path / "empty.obj"
    empty.write_text("v 0 0 0\nv 1 0 0\n")
    with pytest.raises(wv.MeshError, match="empty.obj"):
        read_surface(empty)


def test_landmarks_file_is_json_ready():
    layout = wv.load_layout(EXAMPLE)
    assert set(layout.landmarks) == set(wv.datasets.LANDMARKS)
    json.dumps(layout.to_dict())


# ---------------------------------------------------------------------- orientation
def _write_obj(path, points, triangles):
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in points]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles]
    path.write_text("\n".join(lines) + "\n")


def _flipped(triangles, how):
    t = np.array(triangles)
    if how == "inside out":
        return t[:, ::-1]
    mixed = np.random.default_rng(7).random(len(t)) < 0.4  # 40 % of the triangles flipped
    t[mixed] = t[mixed][:, ::-1]
    return t


@needs_scans
@pytest.mark.parametrize("how", ["inside out", "mixed"])
def test_a_badly_oriented_scan_is_read_facing_outward(tmp_path, how):
    good = read_surface(HEAD)
    path = tmp_path / "head.obj"
    _write_obj(path, good.points, _flipped(good.triangles, how))
    back = read_surface(path)
    np.testing.assert_array_equal(back.triangles, good.triangles)
    assert back.signed_volume() > 0


@needs_scans
@pytest.mark.parametrize("how", ["inside out", "mixed"])
def test_a_face_on_a_badly_oriented_scan_has_its_skull_inside(tmp_path, how, example_scan):
    good = read_surface(HEAD)
    path = tmp_path / "head.obj"
    _write_obj(path, good.points, _flipped(good.triangles, how))
    face = wv.datasets.load_face(skin=path, layout=EXAMPLE)
    ref = example_scan.with_skin_model(example_scan.skin_model)  # the scan read as it is
    np.testing.assert_array_equal(face.skull.points, ref.skull.points)
    assert 0 < face.skull.signed_volume() < 0.9 * face.skin.signed_volume()  # inside
    state, expected = face.evaluate("surprise"), ref.evaluate("surprise")
    np.testing.assert_array_equal(state.points, expected.points)  # wrinkles push outward


@pytest.mark.parametrize("how", ["inside out", "mixed"])
def test_an_open_scan_is_turned_outward(how):
    """The built-in skin is open (a mask): outward means away from its middle."""
    from wrinkle_vis.datasets.scans import orient_outward

    skin = wv.datasets.load_face().skin
    bad = wv.TriangleSurface(skin.points, _flipped(skin.triangles, how))
    np.testing.assert_array_equal(orient_outward(bad).triangles, skin.triangles)
    assert orient_outward(skin) is skin


def test_each_component_is_turned_outward_on_its_own():
    from meshes import sphere

    from wrinkle_vis.datasets.scans import orient_outward

    a, b = sphere(2), sphere(2)
    pts = np.vstack([a.points, b.points + [5.0, 0, 0]])
    tri = np.vstack([a.triangles, b.triangles[:, ::-1] + a.n_points])  # the second inside out
    out = orient_outward(wv.TriangleSurface(pts, tri))
    np.testing.assert_array_equal(out.triangles[len(a.triangles):],
                                  b.triangles + a.n_points)
    np.testing.assert_array_equal(out.triangles[:len(a.triangles)], a.triangles)


def test_a_non_orientable_scan_is_refused_with_the_way_out(tmp_path):
    n = 24  # a Moebius strip
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    pts = []
    for s in (-1.0, 1.0):
        r = 10 + 2 * s * np.cos(t / 2)
        pts.append(np.c_[r * np.cos(t), r * np.sin(t), 2 * s * np.sin(t / 2)])
    pts = np.vstack(pts)
    tris = []
    for i in range(n):
        j = (i + 1) % n
        a, b = i, n + i  # the strip's two sides at i
        c, d = (j, n + j) if j else (n, 0)  # the twist swaps them at the seam
        tris += [(a, c, b), (b, c, d)]
    path = tmp_path / "moebius.obj"
    _write_obj(path, pts, tris)
    with pytest.raises(wv.MeshError, match="moebius.obj: the triangles cannot be oriented "
                                           "consistently.*Re-Orient all faces coherently"):
        read_surface(path)


@pytest.fixture(scope="module")
def raw_scan():
    """The raw head scan with the example's landmarks (the README's scan example)."""
    return wv.datasets.load_face(skin=HEAD, landmarks=wv.datasets.read_landmarks(EXAMPLE),
                                 unit="m")


@needs_scans
@pytest.mark.parametrize("refine", [False, True])
def test_on_the_raw_scan_no_sheet_wrinkles_skin_hidden_behind_skin(refine, raw_scan):
    """Issue 32: on the raw head scan (the README's scan example) the frontalis wrinkled
    the hidden roof of the eye socket, 25 mm behind the forehead: W 2.6 mm there against
    0.35 mm on the forehead, and that value set the summary and the colour ranges. Every
    vertex a sheet wrinkles is seen from outside along the sheet's normal (VTK's ray
    tracer: the ray from half the sheet's width out meets no skin), and the largest |W| is
    on skin that faces the sheet."""
    face = raw_scan
    skin = to_surface_polydata(face.skin)
    centre = face.skin.points.mean(axis=0)
    for expression in ("surprise", "fear"):
        state = face.evaluate(expression, refine=refine)
        normals = face.skin.vertex_normals()
        for m in face.muscles:
            if m.type_name != "sheet" or not state.activations[m.name]:
                continue
            _, _, n = m.frame
            out = n if (m.insertion_center - centre) @ n >= 0 else -n
            step = 0.5 * m.width_value  # skin farther behind skin: another layer
            wrinkled = np.flatnonzero(np.nan_to_num(state.fields[m.name]["W"]) != 0)
            assert len(wrinkled) > 10
            for x in state.rest_points[wrinkled]:
                hits, _ = skin.ray_trace(x + step * out, x + 0.3 * out)
                assert not len(hits), f"{m.name} wrinkles {x}, behind skin at {hits[0]}"
        if not refine:
            top = int(np.argmax(np.abs(state.W)))
            assert normals[top] @ [0.0, 0.33, 0.94] > 0.5  # the forehead's outward normal
        assert np.abs(state.W).max() < 1.5e-3  # metres: was 2.6 mm in the socket
