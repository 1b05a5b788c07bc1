import json
import os
import subprocess
import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.cli import main


def test_render_writes_a_png(tmp_path, capsys):
    out = tmp_path / "w.png"
    assert main(["render", "-e", "frown", "--camera", "forehead", "--size", "200", "160",
                 "-o", str(out)]) == 0
    assert iio.imread(out).shape[:2] == (160, 200)
    assert "wrote" in capsys.readouterr().out


def test_render_per_muscle_field_and_layers(tmp_path):
    out = tmp_path / "g.png"
    assert main(["render", "-f", "gamma", "-m", "corrugator_R", "-e", "frown",
                 "--layers", "skin", "skull", "--size", "120", "120", "-o", str(out)]) == 0
    assert out.is_file()


def test_export_carries_every_field(tmp_path):
    out = tmp_path / "fear.vtp"
    assert main(["export", "-e", "fear", "-o", str(out)]) == 0
    mesh = pv.read(out)
    assert "W" in mesh.point_data and "corrugator_L__eps" in mesh.point_data
    assert np.isnan(mesh["corrugator_L__W"]).any() and np.nanmax(np.abs(mesh["W"])) > 0


def test_export_all_layers(tmp_path):
    out = tmp_path / "fear.vtm"
    assert main(["export", "-e", "fear", "-o", str(out)]) == 0
    blocks = pv.read(out)
    assert set(blocks.keys()) == {"skin", "skull", "muscles"}
    assert "W" in blocks["skin"].point_data and len(blocks["muscles"]) == 21
    assert blocks["muscles"]["corrugator_L"]["activation"].max() == pytest.approx(0.8)


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_animate(tmp_path, suffix):
    out = tmp_path / f"s{suffix}"
    assert main(["animate", "-e", "surprise", "--fps", "3", "--size", "96", "96",
                 "-o", str(out)]) == 0
    if suffix == ".gif":
        n_frames = len(iio.imread(out, index=None))
    else:  # imageio's ffmpeg reader leaks its pipes; ask ffmpeg directly
        import imageio_ffmpeg

        n_frames = imageio_ffmpeg.count_frames_and_secs(str(out))[0]
    assert n_frames == 10  # 3 s of onset, hold and release at 3 fps, both ends


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["render", "-f", "eps", "-o", "x.png"], "belongs to one muscle"),
        (["render", "-m", "nose", "-o", "x.png"], "unknown muscle 'nose'"),
        (["render", "-e", "laughing", "-o", "x.png"], "unknown expression 'laughing'"),
        (["export", "-o", "x.step"], "must end in .vtp, .vtu, .vtk, .ply, .obj, .stl, .vtm "
                                     "or .glb"),
        (["animate", "-o", "x.avi"], "must end in .gif or .mp4"),
    ],
)
def test_bad_arguments_are_reported_without_traceback(argv, message, capsys, tmp_path,
                                                       monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["render", "--camera", "top", "-o", "x.png"], "invalid choice: 'top'"),
        (["render"], "required: --output"),
        (["render", "-o", "x.png", "--intensity", "2"], "outside [0, 1]"),
        (["export", "-o", "x.vtp", "--layout", "missing.json"], "no such file"),
        (["dance"], "invalid choice: 'dance'"),
    ],
)
def test_parser_errors(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2 and message in capsys.readouterr().err


def test_help_reads_well(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    for cmd in ("summary", "render", "export", "animate"):
        assert cmd in out


# ---------------------------------------------------------------------- one-line errors
CLI = Path(sys.executable).with_name("wrinkle-vis")


def _layouts(folder: Path) -> None:
    """Broken layout files, named by what is wrong with them."""
    good = json.loads(wv.datasets.BUILTIN_LAYOUT.read_text())
    (folder / "badjson.json").write_text('{"format": "wrinkle-vis-layout",')
    (folder / "latin1.json").write_bytes(json.dumps(good).encode()[:40] + b"caf\xe9\n}")
    (folder / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    (folder / "format.json").write_text('{"format": "x"}')
    (folder / "noskin.json").write_text(json.dumps({**good, "skin": "scans/missing.obj"}))
    (folder / "noskull.json").write_text(json.dumps({**good, "skull": "missing.obj"}))
    (folder / "long.json").write_text(json.dumps({**good, "expressions": {
        **good["expressions"], "surprise": {**good["expressions"]["surprise"],
                                            "hold_s": 100_000}}}))
    (folder / "file.txt").write_text("in the way")


BAD_INPUTS = [
    # (argv, what the one line says)
    (["render", "-o", "noext"], "--output must end in .png; got 'noext' (e.g. 'noext.png')"),
    (["render", "-o", "x.jpg"], "--output must end in .png; got 'x.jpg'"),
    (["render", "-o", "."], "'.' is a folder; give a file name inside it"),
    (["render", "-o", "missing/x.png"], "folder"),
    (["render", "-o", "file.txt/x.png"], "is not a folder"),
    (["render", "--size", "0", "0", "-o", "x.png"], "--size 0 0 is too small"),
    (["render", "--size", "-5", "100", "-o", "x.png"], "--size -5 100 is too small"),
    (["render", "--size", "100000", "100000", "-o", "x.png"],
     "too large (at most 16384 pixels each way"),
    (["render", "--size", "16384", "16384", "-o", "x.png"], "e.g. 8192 8192"),
    (["figure", "fig9", "--size", "9000", "9000", "-o", "x.png"], "too large"),
    (["animate", "--fps", "0", "-o", "x.gif"], "--fps 0 is outside 1..120"),
    (["animate", "--fps", "-3", "-o", "x.gif"], "--fps -3 is outside 1..120"),
    (["animate", "--size", "0", "0", "-o", "x.gif"], "too small"),
    (["animate", "-o", "x"], "--output must end in .gif or .mp4"),
    (["animate", "--layout", "long.json", "-o", "x.gif"],
     "1,200,025 frames at 12 fps, more than 10,000; shorten the expression's hold_s in "
     "the layout (even 1 fps makes 100,003 frames)"),
    (["summary", "--triangles", "10"], "--triangles 10 is outside 500..250000"),
    (["export", "--triangles", "300000", "-o", "x.vtp"], "outside 500..250000"),
    (["export", "-o", "x"], "--output must end in .vtp, .vtu, .vtk, .ply, .obj, .stl, .vtm "
                                "or .glb; got 'x'"),
    (["export", "-o", "file.txt/x.vtp"], "is not a folder"),
    (["figure", "fig9", "-o", "noext"], "--output must end in .png"),
    (["summary", "--layout", "badjson.json"], "badjson.json: line 1 column 33: expected valid"),
    (["summary", "--layout", "latin1.json"], "latin1.json: line 1 (byte 43): expected UTF-8"),
    (["summary", "--layout", "deep.json"], "deep.json: $: expected JSON nested at most"),
    (["render", "--layout", "format.json", "-o", "x.png"],
     "format.json: $.format: expected 'wrinkle-vis-layout'"),
    (["export", "--layout", "noskin.json", "-o", "x.vtp"],
     "its skin file"),
    (["export", "--layout", "noskull.json", "-o", "x.vtp"], "its skull file"),
]


@pytest.mark.parametrize(("argv", "message"), BAD_INPUTS,
                         ids=[" ".join(a) for a, _ in BAD_INPUTS])
def test_every_error_is_one_line_with_exit_status_2(argv, message, capsys, tmp_path,
                                                    monkeypatch):
    monkeypatch.chdir(tmp_path)
    _layouts(tmp_path)
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1, err
    assert err.startswith(f"wrinkle-vis {argv[0]}: ") and message in err
    assert "Traceback" not in err
    assert not any(p.suffix in (".png", ".gif", ".vtp") for p in tmp_path.iterdir())


@pytest.mark.parametrize("argv", [
    ["render", "-o", "noext"], ["render", "-o", "x.png", "--size", "5", "5"],
    ["export", "-o", "."], ["animate", "-o", "missing/x.gif"],
])
def test_outputs_are_checked_before_any_work(argv, tmp_path, monkeypatch, capsys):
    import wrinkle_vis.datasets

    def no_face(*args, **kwargs):
        raise AssertionError("the face was built before the output was checked")

    monkeypatch.setattr(wrinkle_vis.datasets, "load_face", no_face)
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_layout_errors_in_a_real_process_are_one_line(tmp_path):
    _layouts(tmp_path)
    for argv in (["summary", "--layout", "format.json"], ["summary", "--layout", "latin1.json"],
                 ["summary", "--layout", "deep.json"], ["summary", "--triangles", "10"],
                 ["render", "--size", "100000", "100000", "-o", "x.png"],
                 ["summary", "--layout", "file.txt/x.json"], ["export", "-o", "x.step"]):
        done = subprocess.run([str(CLI), *argv], cwd=tmp_path, capture_output=True,
                              text=True, timeout=300)
        assert done.returncode == 2, (argv, done.stderr)
        assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, done.stderr


@pytest.mark.parametrize(("name", "message"), [
    ("latin1.json", "expected UTF-8 text"),
    ("deep.json", "expected JSON nested at most"),
    ("badjson.json", "expected valid JSON"),
])
def test_unreadable_layouts_raise_layout_error(tmp_path, name, message):
    _layouts(tmp_path)
    with pytest.raises(wv.LayoutError, match=message) as info:
        wv.load_layout(tmp_path / name)
    assert str(tmp_path / name) in str(info.value)


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"wrinkle-vis {wv.__version__}"


def test_render_reports_the_file_it_wrote(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["render", "--size", "64", "48", "-o", "w.png"]) == 0
    assert capsys.readouterr().out.strip() == "wrote w.png"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.png"]


def test_export_through_a_link_says_where_it_went(tmp_path, capsys):
    (tmp_path / "real").mkdir()
    (tmp_path / "face.vtp").symlink_to(tmp_path / "real" / "face.vtp")
    assert main(["export", "-o", str(tmp_path / "face.vtp")]) == 0
    assert f"(through the link, to {tmp_path / 'real' / 'face.vtp'})" in \
        capsys.readouterr().out
    assert (tmp_path / "face.vtp").is_symlink() and pv.read(tmp_path / "face.vtp").n_points


def _free_display() -> str:
    """An X display number no server here listens on (CI runs Xvfb servers of its own)."""
    for n in range(917, 999):
        if not Path(f"/tmp/.X11-unix/X{n}").exists() and not Path(f"/tmp/.X{n}-lock").exists():
            return f":{n}"
    pytest.skip("no free X display number to test an unreachable display with")


def _env(**changes):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY",
                                                            "QT_QPA_PLATFORM")}
    env.update(changes)
    return env


@pytest.mark.parametrize("display", [None, "free"], ids=["no DISPLAY", "unreachable DISPLAY"])
def test_the_app_without_a_display_says_how_to_work_headless(tmp_path, display):
    env = _env(**({"DISPLAY": _free_display()} if display else {}))
    done = subprocess.run([str(CLI)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert "wrinkle-vis render" in done.stderr and "wrinkle-vis summary" in done.stderr
    assert "xvfb-run" in done.stderr


@pytest.mark.parametrize("display", [None, "free"], ids=["no DISPLAY", "unreachable DISPLAY"])
def test_a_headless_render_prints_no_x_server_warning(tmp_path, display):
    env = _env(**({"DISPLAY": _free_display()} if display else {}))
    done = subprocess.run([str(CLI), "render", "--size", "64", "64", "-o", "w.png"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "wrote w.png" and done.stderr == ""
    assert iio.imread(tmp_path / "w.png").shape[:2] == (64, 64)


# ---------------------------------------------------------------------- animate
def test_animate_takes_field_muscle_and_layers(tmp_path):
    out = tmp_path / "g.gif"
    assert main(["animate", "-e", "frown", "-f", "gamma", "-m", "corrugator_L", "--layers",
                 "skin", "muscles", "--fps", "2", "--size", "64", "48", "-o", str(out)]) == 0
    frames = iio.imread(out, index=None)
    assert frames.shape == (7, 48, 64, 3)  # 3 s at 2 fps, both ends


def test_animate_needs_a_muscle_for_a_per_muscle_field(tmp_path, capsys):
    assert main(["animate", "-f", "eps", "-o", str(tmp_path / "x.gif")]) == 2
    assert "belongs to one muscle: add --muscle NAME" in capsys.readouterr().err


def test_animate_refuses_absurd_frame_counts_before_rendering(tmp_path, capsys, monkeypatch):
    import wrinkle_vis.plotting.animation as animation

    _layouts(tmp_path)
    monkeypatch.setattr(animation, "animation_frames", None)  # never reached
    assert main(["animate", "--layout", str(tmp_path / "long.json"), "--fps", "1",
                 "-o", str(tmp_path / "x.gif")]) == 2
    err = capsys.readouterr().err
    assert "100,003 frames at 1 fps, more than 10,000" in err and "hold_s" in err


def test_frame_times_say_how_far_to_lower_the_fps():
    from wrinkle_vis.plotting.animation import TooManyFramesError, frame_times

    ex = wv.Expression("long", {}, onset_s=1.0, hold_s=998.0, release_s=1.0)  # 1000 s
    assert len(frame_times(ex, 9)) == 9001
    with pytest.raises(TooManyFramesError, match="lower the fps to 9 or less"):
        frame_times(ex, 12)


# ---------------------------------------------------------------------- n_w against the mesh
def test_undersampled_wrinkles_are_one_warning_line(tmp_path, capsys):
    out = tmp_path / "f.png"
    assert main(["render", "-e", "frown", "--size", "64", "64", "-o", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1, err  # the two corrugators share a line
    line = err[0]
    assert line.startswith("wrinkle-vis render: warning: muscles 'corrugator_L', "
                           "'corrugator_R': wrinkle half period u = 4.05")
    # 5.89 mm: the even mesh's 5.94 less the lips' finer edges (datasets.face.mesh_density)
    assert "median edge length 5.89" in line and "refine the skin" in line
    assert "lower n_w to 1" in line
    assert main(["render", "-e", "surprise", "--size", "64", "64", "-o", str(out)]) == 0
    assert capsys.readouterr().err == ""  # the frontalis' wrinkles are resolved



def test_a_layout_alone_opens_the_app_on_it(tmp_path, monkeypatch, capsys):
    import wrinkle_vis.app.window as window
    import wrinkle_vis.plotting.offscreen as offscreen

    layout = tmp_path / "mine.json"
    wv.save_layout(wv.load_layout(wv.datasets.BUILTIN_LAYOUT), layout)
    opened = []
    monkeypatch.setattr(offscreen, "display_available", lambda: True)
    monkeypatch.setattr(window, "run", lambda argv, layout=None: opened.append(layout) or 0)
    assert main([str(layout)]) == 0
    assert opened == [str(layout)]
    with pytest.raises(SystemExit) as info:
        main([str(tmp_path / "missing.json")])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no such file" in err and "missing.json" in err


def test_a_layout_alone_without_a_display_says_how_to_work_headless(tmp_path):
    layout = tmp_path / "mine.json"
    wv.save_layout(wv.load_layout(wv.datasets.BUILTIN_LAYOUT), layout)
    done = subprocess.run([str(CLI), str(layout)], cwd=tmp_path, env=_env(),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "xvfb-run" in done.stderr


def test_the_library_renders_headless_without_the_x_server_warning(tmp_path):
    code = ("import wrinkle_vis as wv; from wrinkle_vis.plotting import render_field; "
            "render_field(wv.datasets.load_face(), 'frown', size=(64, 64), filename='w.png')")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=_env(),
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stderr == "" and (tmp_path / "w.png").is_file()


def test_undersampled_wrinkles_of_several_muscles_are_one_line(capsys):
    """summary on the default face: every muscle at work whose wrinkles alias (corrugators,
    orbicularis oculi, orbicularis oris) in one warning line, not one line per twin pair.
    """
    assert main(["summary"]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert len(err) == 1, err
    for name in ("corrugator_L", "corrugator_R", "orbicularis_oculi_L", "orbicularis_oris"):
        assert repr(name) in err[0]
    assert "n_w 1 fits" in err[0] and "refine the skin (about" in err[0]


@pytest.mark.parametrize(("flag", "refine"), [("on", False), ("fans", False), ("on", True),
                                             ("light", True)])
def test_fold_guard_fans_reaches_the_wrinkle_step(flag, refine, tmp_path, monkeypatch):
    """``--fold-guard fans`` guards the frame with ``FoldGuard(fans=True)``: the fans'
    guard runs on the export's frame (``on``: the default guard, without it unrefined and
    with it refined; ``light``: without it, refined too)."""
    from wrinkle_vis.core import foldguard

    calls = []

    def guard_fans(*args, **kwargs):
        calls.append(len(args[0]))
        return original(*args, **kwargs)

    original = foldguard.guard_fans
    monkeypatch.setattr(foldguard.frame, "guard_fans", guard_fans)
    out = tmp_path / "surprise.vtp"
    if refine:  # (a refined frame: the render's)
        out = tmp_path / "surprise.png"
        args = ["render", "--refine", "--field", "none", "--size", "160", "160"]
    else:
        args = ["export"]
    assert main(args + ["-e", "surprise", "--fold-guard", flag, "-o", str(out)]) == 0
    assert out.is_file() and (len(calls) > 0) == (flag == "fans" or (refine and flag == "on"))


def test_a_bad_fold_guard_is_one_line(capsys):
    with pytest.raises(SystemExit) as info:
        main(["export", "-o", "x.vtp", "--fold-guard", "maybe"])
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1, err
    assert "--fold-guard: invalid choice: 'maybe' (choose from 'on', 'off', 'fans', 'light')" in err
