"""Refined triangles located on the skin they refine (root triangle, barycentrics), and
`bake --refine`, whose UVs come from them.
"""

import json

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.cli import main
from wrinkle_vis.core.parametric import refined_root_coordinates


@pytest.fixture(scope="module")
def head(wv_head):
    return wv_head.with_skin_model(wv_head.skin_model)  # the session's caches (conftest)


def _areas(corners_2d: np.ndarray) -> np.ndarray:
    a, b, c = corners_2d[:, 0], corners_2d[:, 1], corners_2d[:, 2]
    return 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                        - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))


def test_refined_triangles_tile_their_root_triangles(head):
    from wrinkle_vis.datasets.lee_perry_smith import lee_perry_smith_uvs

    state = head.evaluate("surprise", refine=True)
    assert state.face.skin.n_triangles > head.skin.n_triangles
    root, bary = refined_root_coordinates(head, state)
    np.testing.assert_allclose(bary.sum(axis=2), 1.0, atol=1e-12)
    assert bary.min() >= -1e-12 and bary.max() <= 1 + 1e-12
    # the refined triangles partition each root triangle: in UV space (seams and all) their
    # areas add up to their root's, and every root triangle is covered
    uvs = lee_perry_smith_uvs()
    refined_uv = np.einsum("mij,mjk->mik", bary, uvs[root])
    total = np.bincount(root, _areas(refined_uv), minlength=head.skin.n_triangles)
    np.testing.assert_allclose(total, _areas(uvs), rtol=1e-9, atol=1e-15)
    # on the flat root triangles, the corners lie near the refined rest skin (which bulges
    # off them, Phong) and exactly on the root skin's own vertices
    skin = head.skin
    flat = np.einsum("mij,mjd->mid", bary, skin.points[skin.triangles[root]])
    rest = state.face.skin.points[state.face.skin.triangles]
    gap = np.linalg.norm(flat - rest, axis=2)
    assert gap.max() < 0.25 * np.median(skin.rest_edge_lengths)
    kept = state.face.skin.triangles < skin.n_points  # the root skin's vertices
    np.testing.assert_allclose(gap[kept], 0.0, atol=1e-9)


def test_an_unrefined_frame_is_its_own_root(head):
    root, bary = refined_root_coordinates(head, head.evaluate("surprise"))
    np.testing.assert_array_equal(root, np.arange(head.skin.n_triangles))
    np.testing.assert_array_equal(bary, np.broadcast_to(np.eye(3), bary.shape))


def test_bake_refine_bakes_the_refined_skin(tmp_path, capsys):
    out = tmp_path / "maps"
    assert main(["bake", "--face", "lee_perry_smith", "--refine", "--size", "96", "96",
                 "--padding", "2", "-o", str(out)]) == 0
    line = capsys.readouterr().out
    meta = json.loads((out / "displacement.json").read_text())
    head = wv.datasets.load_face("lee_perry_smith")
    assert meta["refined"] and meta["triangles"] > head.skin.n_triangles
    assert "within" in line
    assert meta["sampled_back"]["texel_centres_max_fraction_of_range"] < 1e-4
    with pytest.raises(SystemExit):
        main(["bake", "--help"])
    assert "--refine" in capsys.readouterr().out
