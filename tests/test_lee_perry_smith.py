"""The Lee Perry-Smith head built in: compact, in millimetres, with UVs, a closed skull and
the procedural face's muscles, whose wrinkles read (surprise: n_w crests on every forehead line)."""

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.core.analysis import region_union, section_extrema
from wrinkle_vis.core.mesh import closest_points, self_intersections
from wrinkle_vis.datasets import lee_perry_smith as lps
from wrinkle_vis.datasets.skull import exterior

ROOT = Path(__file__).resolve().parents[1]
HEAD = ROOT.parent / "shared" / "realmeshes" / "lee_perry_smith_head.obj"
FOREHEAD_X = (-40.0, -24.0, -8.0, 8.0, 24.0, 40.0)


@pytest.fixture(scope="module")
def head(wv_head):
    return wv_head.with_skin_model(wv_head.skin_model)  # the session's caches (conftest)


def test_loads_fast_from_the_package(tmp_path):
    code = ("import time; t = time.perf_counter(); import wrinkle_vis as wv; "
            "f = wv.datasets.load_face('lee_perry_smith'); "
            "print(time.perf_counter() - t, f.skin.n_points)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={"WRINKLE_VIS_CACHE": str(tmp_path),
                                          "PATH": "", "PYTHONPATH": str(ROOT)})
    seconds, n = out.stdout.split()
    assert int(n) == 8844
    assert float(seconds) < 1.0 + 2.0  # < 1 s to load; imports on a busy 2-core box aside
    t = time.perf_counter()
    wv.datasets.load_face("lee_perry_smith")
    assert time.perf_counter() - t < 1.0


def test_the_package_ships_a_compact_derived_form_with_its_credit():
    assert lps.DATA.stat().st_size < 1_500_000  # compressed float32 / uint32 arrays
    with np.load(lps.DATA) as data:
        assert data["skin_points"].dtype == np.float32
        assert data["skin_triangles"].dtype == np.uint32
    assert "CC BY 3.0" in lps.__doc__ and "Lee Perry-Smith" in lps.__doc__
    notice = (Path(lps.__file__).with_name("NOTICE.txt")).read_text()
    assert "Infinite Realities" in notice and "creativecommons.org/licenses/by/3.0" in notice
    assert "NOTICE.txt" in (ROOT / "pyproject.toml").read_text()
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True)
    assert not any(p.endswith(".obj") for p in tracked.stdout.split())  # never the scan


def test_welded_millimetres_builtin_frame(head):
    rep = head.skin.report()
    assert rep.n_components == 1 and len(rep.non_manifold_edges) == 0
    assert rep.consistently_oriented and head.unit == "mm"
    lo, hi = head.skin.bounds()
    assert 380 < hi[1] - lo[1] < 440  # the 0.42 m scan in mm, y up
    marks = head.landmarks
    assert marks["nose_tip"][2] > marks["nasion"][2] > marks["eye_outer_L"][2]  # faces +z
    assert marks["eye_outer_L"][0] > 30 > -30 > marks["eye_outer_R"][0]  # x: subject's left
    assert abs(marks["nasion"][1] - 8.0) < 8.0  # origin between the eyes (as built in)


def test_uvs_per_corner(head):
    uvs = lps.lee_perry_smith_uvs()
    assert uvs.shape == (head.skin.n_triangles, 3, 2)
    assert uvs.min() >= 0.0 and uvs.max() <= 1.0


@pytest.mark.skipif(not HEAD.exists(), reason="../shared/realmeshes is not here")
def test_uvs_are_the_scans(head):
    from wrinkle_vis.datasets import read_surface
    from wrinkle_vis.plotting.bake import read_obj_uvs

    scan = read_surface(HEAD)
    np.testing.assert_allclose(lps.lee_perry_smith_uvs(), read_obj_uvs(HEAD, scan), atol=1e-6)
    np.testing.assert_array_equal(head.skin.triangles, scan.triangles)


def test_closed_skull_inside(head):
    rep = head.skull.report()
    assert len(rep.boundary_edges) == 0 and len(rep.non_manifold_edges) == 0
    assert rep.n_components == 1 and len(self_intersections(head.skull)) == 0
    outer = exterior(head.skin)  # the face's surface, not the mouth bag or eye sockets
    gap = np.linalg.norm(closest_points(outer, head.skull.points[::25])
                         - head.skull.points[::25], axis=1)
    assert gap.min() > 1.0


def test_muscles_named_as_the_procedural_face_and_placed(head):
    procedural = wv.load_layout(wv.datasets.BUILTIN_LAYOUT)
    assert head.muscle_names == tuple(m.name for m in procedural.muscles)
    assert len(head.muscles) >= 14  # 21 with the sphincters and the action-unit muscles
    for m in head.muscles:
        for p in [p for p in m.point_parameters if np.ndim(getattr(m, p)) == 1]:
            pts = np.asarray(getattr(m, p))[None]
            surf = head.skull if p.startswith("attachment") else head.skin
            assert np.linalg.norm(closest_points(surf, pts) - pts) < 1e-6


@pytest.mark.slow
def test_surprise_furrows_the_forehead_with_n_w_crests_on_every_line(head):
    state = head.evaluate("surprise", refine=True)
    mask = region_union(state.face, "frontalis")
    rows = section_extrema(state.face.skin, state.W, 0, FOREHEAD_X, mask, 0.1)
    n_w = {m.n_wrinkles for m in head.muscles if m.name.startswith("frontalis")}
    assert len(n_w) == 1
    assert [r["crests"] for r in rows] == [n_w.pop()] * len(FOREHEAD_X)
    assert np.median([d for r in rows for d in r["depths"]]) >= 0.6  # deep furrows


@pytest.mark.slow
def test_frown_furrows_between_the_brows(head):
    state = head.evaluate("frown", refine=True)
    rest = state.rest_points
    mask = region_union(state.face, "corrugator") & (np.abs(rest[:, 0]) < 20.0)
    rows = section_extrema(state.face.skin, state.W, 1, (20.0, 24.0, 28.0), mask, 0.1)
    assert all(r["crests"] >= 2 for r in rows)
    deep = [p for r in rows for p, d in zip(r["furrow_points"], r["depths"], strict=True)
            if d >= 0.6]
    assert len(deep) >= 2 and np.abs(np.asarray(deep)[:, 0]).max() < 16.0


def test_names(head):
    assert wv.datasets.FACES == ("procedural", "lee_perry_smith")
    assert wv.datasets.load_face("procedural", n_triangles=4500).skin.n_triangles == 4500
    assert wv.datasets.load_face().skin.n_triangles == 4500
    with pytest.raises(ValueError, match=r"^no built-in face 'bob'; the built-in faces are: "
                                         r"procedural, lee_perry_smith$"):
        wv.datasets.load_face("bob")


def test_a_layout_for_the_head_reopens_on_it(head, tmp_path):
    path = tmp_path / "mine.json"
    wv.save_layout(wv.load_layout(lps.LAYOUT), path)
    again = wv.datasets.load_face(layout=path)  # "face": "lee_perry_smith", skin null
    np.testing.assert_array_equal(again.skin.points, head.skin.points)
    assert again.muscle_names == head.muscle_names
