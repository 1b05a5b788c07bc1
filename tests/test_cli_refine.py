"""``--refine`` of the ``render``, ``animate`` and ``figure`` commands, off screen."""

import imageio.v3 as iio
import numpy as np
import pytest

import wrinkle_vis.plotting.animation as animation
import wrinkle_vis.plotting.figures as figures
import wrinkle_vis.plotting.scenes as scenes
from wrinkle_vis.cli import main
from wrinkle_vis.plotting.animation import frame_times


@pytest.fixture
def drawn(monkeypatch):
    """The states whose skin the plotting functions draw, in order (``add_skin`` spied
    on where ``render``, ``animate`` and ``figure`` call it).
    """
    states = []

    def spy(original):
        def add_skin(plotter, state, *args, **kwargs):
            states.append(state)
            return original(plotter, state, *args, **kwargs)
        return add_skin

    for module in (scenes, animation, figures):
        monkeypatch.setattr(module, "add_skin", spy(module.add_skin))
    return states


def test_render_refine_draws_the_refined_skin(tmp_path, drawn, wv_face):
    plain, refined, shallow = (tmp_path / f"{n}.png" for n in ("plain", "refined", "shallow"))
    common = ["render", "-e", "surprise", "--camera", "forehead", "--size", "160", "160"]
    assert main([*common, "-o", str(plain)]) == 0
    assert main([*common, "--refine", "-o", str(refined)]) == 0
    assert main([*common, "--refine", "--refine-levels", "1", "--refine-angle", "6",
                 "-o", str(shallow)]) == 0
    n_plain, n_refined, n_shallow = (len(s.triangles) for s in drawn)
    assert n_plain == wv_face.skin.n_triangles
    assert n_refined == len(wv_face.evaluate("surprise", refine=True).triangles) > n_plain
    assert n_shallow == len(wv_face.evaluate("surprise", refine=True, refine_levels=1,
                                             refine_angle_deg=6.0).triangles)
    assert n_plain < n_shallow < n_refined
    a, b = (iio.imread(p).astype(int) for p in (plain, refined))
    assert a.shape == b.shape and np.abs(a - b).max() > 40  # the furrows are drawn finer


def test_animate_refine_refines_every_frame_that_wrinkles(tmp_path, drawn, wv_face):
    """Each frame of the animation is the refined still frame of its time (the geometric
    skin: on the physical one an animation is simulated, with inertia)."""
    out = tmp_path / "r.gif"
    assert main(["animate", "-e", "frown", "--fps", "2", "--size", "64", "64", "--refine",
                 "--refine-levels", "2", "--skin-model", "geometric", "-o", str(out)]) == 0
    wv_face = wv_face.with_skin_model("geometric")
    ex = wv_face.expressions["frown"]
    times = frame_times(ex, 2)
    assert len(iio.imread(out, index=None)) == len(times)
    frames = drawn[-len(times):]
    assert [len(s.triangles) for s in frames] == [
        len(wv_face.evaluate(ex.at(float(t)), refine=True, refine_levels=2).triangles)
        for t in times]
    assert len(frames[0].triangles) == wv_face.skin.n_triangles  # at rest: nothing bends
    assert max(len(s.triangles) for s in frames) > wv_face.skin.n_triangles


def test_fig11_takes_the_refinement_options_without_refine(tmp_path, drawn, wv_face):
    assert main(["figure", "fig11", "--refine-levels", "1", "--size", "96", "96",
                 "-o", str(tmp_path / "f.png")]) == 0
    assert len(drawn[-1].triangles) == len(
        wv_face.evaluate("surprise", refine=True, refine_levels=1).triangles)


@pytest.mark.parametrize(("argv", "message"), [
    (["render", "--refine", "--refine-angle", "0", "-o", "x.png"],
     "--refine-angle 0 is outside (0, 180) degrees"),
    (["render", "--refine", "--refine-angle", "180", "-o", "x.png"],
     "--refine-angle 180 is outside (0, 180) degrees"),
    (["animate", "--refine", "--refine-levels", "9", "-o", "x.gif"],
     "--refine-levels 9 is outside 0..5"),
    (["animate", "--refine", "--refine-levels", "-1", "-o", "x.gif"],
     "--refine-levels -1 is outside 0..5"),
    (["render", "--refine-levels", "2", "-o", "x.png"], "--refine-levels sets how the skin "
                                                        "is refined; add --refine"),
    (["figure", "fig9", "--refine-angle", "5", "-o", "x.png"], "add --refine"),
])
def test_bad_refinement_values_are_one_line_before_any_work(argv, message, tmp_path,
                                                            monkeypatch, capsys):
    import wrinkle_vis.datasets

    def no_face(*args, **kwargs):
        raise AssertionError("the face was built before the arguments were checked")

    monkeypatch.setattr(wrinkle_vis.datasets, "load_face", no_face)
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and message in err, err
    assert err.startswith(f"wrinkle-vis {argv[0]}: ")
    assert not list(tmp_path.iterdir())


def test_a_refinement_value_that_is_not_a_number_is_a_parser_error(capsys):
    with pytest.raises(SystemExit) as info:
        main(["render", "--refine", "--refine-angle", "steep", "-o", "x.png"])
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1
    assert "--refine-angle: invalid float value: 'steep'" in err
