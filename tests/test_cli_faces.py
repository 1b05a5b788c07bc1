"""The CLI on every face: --face NAME, --skin PATH with --landmarks FILE.json, --unit."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.cli import COMMANDS, _parser, main

ROOT = Path(__file__).resolve().parents[1]
HEAD = ROOT.parent / "shared" / "realmeshes" / "lee_perry_smith_head.obj"
EXAMPLE = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"
needs_scans = pytest.mark.skipif(not HEAD.exists(), reason="../shared/realmeshes is not here")


def test_every_subcommand_takes_face_skin_landmarks_and_unit():
    from wrinkle_vis.cli import FACE_CHOICES

    assert FACE_CHOICES == wv.datasets.FACES
    parser = _parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name in COMMANDS:
        flags = {f for a in sub.choices[name]._actions for f in a.option_strings}
        assert {"--face", "--skin", "--landmarks", "--unit"} <= flags, name


def test_summary_on_the_builtin_head_prints_its_unit(capsys):
    assert main(["summary", "--face", "lee_perry_smith", "-e", "surprise"]) == 0
    out = capsys.readouterr().out
    assert "Lee Perry-Smith" in out and "21 muscles" in out and "W total (mm)" in out


def test_render_the_builtin_head(tmp_path):
    out = tmp_path / "head.png"
    assert main(["render", "--face", "lee_perry_smith", "-f", "none", "--camera",
                 "forehead", "--size", "120", "120", "-o", str(out)]) == 0
    assert out.is_file()


@pytest.mark.parametrize("argv, message", [
    (["summary", "--face", "bob"], "invalid choice: 'bob' (choose from 'procedural', "
                                   "'lee_perry_smith')"),
    (["summary", "--face", "lee_perry_smith", "--triangles", "9000"],
     "--triangles sets the procedural face's resolution"),
    (["summary", "--skin", "nowhere.obj"], "--skin nowhere.obj: no such file"),
    (["summary", "--landmarks", "marks.json"], "landmarks place the muscles on a scan"),
    (["summary", "--unit", "furlong"], "invalid choice: 'furlong'"),
])
def test_bad_face_options_are_one_line(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "marks.json").write_text(json.dumps(
        {k: list(v) for k, v in wv.datasets.builtin_landmarks().items()}))
    try:
        rc = main(argv)
    except SystemExit as exc:  # the parser's own errors
        rc = exc.code
    assert rc == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_a_scan_without_landmarks_says_how_to_give_them(tmp_path, capsys):
    from wrinkle_vis.plotting import to_surface_polydata

    scan = tmp_path / "scan.ply"
    to_surface_polydata(wv.datasets.load_face().skin).save(scan)
    assert main(["summary", "--skin", str(scan)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "a scan needs landmarks to place the muscles; give --landmarks FILE.json" in err
    assert "File > New face from mesh..." in err


def test_the_shipped_example_layout_is_refused_cleanly(capsys):
    """Skin null, metres: it was made for the scan; one line, exit 2, no traceback."""
    proc = subprocess.run([sys.executable, "-m", "wrinkle_vis.cli", "summary", "--layout",
                           str(EXAMPLE)], capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert "made for a face in another unit" in proc.stderr


def test_a_scan_with_landmarks_from_a_file(tmp_path, capsys):
    """The procedural skin saved as a scan (in cm) with its landmarks: muscles placed."""
    from wrinkle_vis.plotting import to_surface_polydata

    face = wv.datasets.load_face()
    scan = tmp_path / "scan.ply"
    to_surface_polydata(face.skin.with_points(face.skin.points / 10.0)).save(scan)
    marks = tmp_path / "marks.json"
    marks.write_text(json.dumps({k: [x / 10.0 for x in v] for k, v in face.landmarks.items()}))
    out = tmp_path / "scan.vtp"
    assert main(["export", "--skin", str(scan), "--landmarks", str(marks), "-e", "surprise",
                 "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert "note: the skin's unit is not given" in captured.err and "reads as cm" in captured.err
    assert np.nanmax(np.abs(pv.read(out)["W"])) > 0  # wrinkles: the muscles were placed
    assert main(["summary", "--skin", str(scan), "--landmarks", str(marks), "--unit", "cm",
                 "-e", "surprise"]) == 0
    captured = capsys.readouterr()
    assert "W total (cm)" in captured.out and "note" not in captured.err


@needs_scans
def test_bake_the_builtin_head_with_its_own_uvs(tmp_path, capsys):
    out = tmp_path / "maps"
    assert main(["bake", "--face", "lee_perry_smith", "--size", "64", "64", "-o",
                 str(out)]) == 0
    meta = json.loads((out / "displacement.json").read_text())
    assert meta["unit"] == "mm"
