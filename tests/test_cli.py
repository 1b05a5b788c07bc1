import imageio.v3 as iio
import numpy as np
import pytest
import pyvista as pv

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
    assert "W" in mesh.point_data and "corrugator_L.eps" in mesh.point_data
    assert np.isnan(mesh["corrugator_L.W"]).any() and np.nanmax(np.abs(mesh["W"])) > 0


def test_export_all_layers(tmp_path):
    out = tmp_path / "fear.vtm"
    assert main(["export", "-e", "fear", "-o", str(out)]) == 0
    blocks = pv.read(out)
    assert set(blocks.keys()) == {"skin", "skull", "muscles"}
    assert "W" in blocks["skin"].point_data and len(blocks["muscles"]) == 14
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
        (["export", "-o", "x.stl"], "must end in .vtp, .vtk, .ply or .vtm"),
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
