"""Hostile command lines get one line and exit code 2, never a traceback (issue 33, M3, M4)."""

import pytest

from wrinkle_vis.cli import main

LONG = "n" * 300


@pytest.mark.parametrize(("argv", "message"), [
    (["render", "-o", f"{LONG}.png"], "File name too long (names have at most 255 bytes"),
    (["export", "-o", f"{LONG}.vtp"], "use a shorter name"),
    (["export", "--sequence", "-o", f"{LONG}_####.ply"], "use a shorter name"),
    (["animate", "-o", f"{LONG}.gif"], "use a shorter name"),
    (["bake", "-o", LONG], "use a shorter name"),
    (["render", "-e", "", "-o", "a.png"], "unknown expression ''; choose from: neutral"),
    (["export", "-e", "", "-o", "a.vtp"], "unknown expression ''"),
    (["export", "--sequence", "-e", "", "-o", "a.pvd"], "unknown expression ''"),
    (["animate", "-e", "", "-o", "a.gif"], "unknown expression ''"),
    (["summary", "-e", ""], "unknown expression ''"),
])
def test_hostile_arguments_are_one_line(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # nothing written
