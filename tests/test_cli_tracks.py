"""The command line with recorded tracks: animate, export --sequence and summary."""

import math
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from wrinkle_vis.cli import main
from wrinkle_vis.core.tracks import Track, write_track

OPENFACE = Path(__file__).resolve().parents[1].parent / "shared" / "tracks" / \
    "openface_test.csv"


@pytest.fixture
def brows(tmp_path):
    """A 0.5 s OpenFace track whose AU04 rises and falls."""
    t = np.linspace(0.0, 0.5, 11)
    path = tmp_path / "frown.csv"
    write_track(Track(t, ["AU04", "AU12"], np.column_stack([np.sin(np.pi * t / 0.5), 0 * t])),
                path, "openface")
    return path


@pytest.mark.parametrize("fps", [12, 30])
def test_animate_a_track_at_its_own_timing(tmp_path, brows, fps, capsys):
    out = tmp_path / "t.gif"
    assert main(["animate", "--track", str(brows), "--fps", str(fps), "--size", "64", "64",
                 "-o", str(out)]) == 0
    frames = iio.imread(out, index=None)
    assert len(frames) == math.floor(0.5 * fps + 1e-9) + 1  # duration x fps, both ends
    assert f"{len(frames)} frames" in capsys.readouterr().out


def test_the_real_track_animates_and_smooths(tmp_path):
    out = tmp_path / "of.gif"
    assert main(["animate", "--track", str(OPENFACE), "--fps", "100", "--smooth", "0.02",
                 "--size", "48", "48", "-o", str(out)]) == 0
    assert len(iio.imread(out, index=None)) == 10  # 0.099 s at 100 frames a second


def test_export_sequence_of_a_track(tmp_path, brows):
    out = tmp_path / "seq.pvd"
    assert main(["export", "--sequence", "--track", str(brows), "--fps", "10",
                 "-o", str(out)]) == 0
    text = out.read_text()
    assert text.count("<DataSet") == 6 and 'timestep="0.5"' in text


def test_summary_names_the_channels_and_their_muscles(brows, capsys):
    assert main(["summary", "--track", str(OPENFACE)]) == 0
    out = capsys.readouterr().out
    assert "openface, 100 frames, 0.099 s" in out
    assert "AU04" in out and "procerus" in out and "corrugator_L x1" in out
    assert "AU45" in out and "drives no muscle" in out
    assert "mentalis" in out.split("muscles driven:")[1]


def test_a_mapping_file(tmp_path, brows, capsys):
    mapping = tmp_path / "map.json"
    mapping.write_text('{"AU04": {"muscles": {"procerus": 0.5}}}')
    assert main(["summary", "--track", str(brows), "--map", str(mapping)]) == 0
    out = capsys.readouterr().out
    assert "AU04" in out and "procerus x0.5" in out and "corrugator" not in out.split("AU04")[1]


@pytest.mark.parametrize("argv, message", [
    (["animate", "--track", "none.csv", "-o", "x.gif"], "--track none.csv: no such file"),
    (["animate", "--track", "empty.csv", "-o", "x.gif"], "the file is empty"),
    (["animate", "--track", "other.csv", "-o", "x.gif"], "not a track this reads"),
    (["summary", "--track", "huge.csv"], "100.0 MiB"),
    (["summary", "--track", "back.csv"], "line 4: time 0.1 s comes before"),
    (["animate", "--track", "good.csv", "--format", "arkit", "-o", "x.gif"],
     "not an ARKit / Live Link Face CSV"),
    (["animate", "--smooth", "0.1", "-o", "x.gif"], "--smooth is an option of a recorded"),
    (["animate", "--track", "good.csv", "--smooth", "-1", "-o", "x.gif"], "must be >= 0"),
    (["summary", "--track", "good.csv", "--map", "nomap.json"], "--map nomap.json: no such"),
    (["summary", "--track", "good.csv", "--map", "badmap.json"], "channel 'AU04'"),
    (["export", "--track", "good.csv", "-o", "x.vtp"], "add --sequence"),
])
def test_bad_tracks_are_one_line(argv, message, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("empty.csv").write_text("")
    Path("other.csv").write_text("name,score\nada,3\n")
    with open("huge.csv", "wb") as f:
        f.truncate(100 * 2**20)
    head = "frame, timestamp, success, AU04_r\n"
    Path("back.csv").write_text(head + "1, 0.0, 1, 1\n2, 0.2, 1, 1\n3, 0.1, 1, 1\n")
    Path("good.csv").write_text(head + "1, 0.0, 1, 1\n2, 0.1, 1, 2\n")
    Path("badmap.json").write_text('{"AU04": {"muscles": {"procerus": 3}}}')
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
