"""Ctrl-C, SIGTERM and SIGHUP stop a command in one line, exit 128 + the signal, with its
temporaries removed, ffmpeg stopped and the old output intact; what a kill -9 leaves goes
at the next write.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import wrinkle_vis.plotting.exchange as exchange
from wrinkle_vis.cli import main
from wrinkle_vis.core.files import clean_stale

CLI = Path(sys.executable).with_name("wrinkle-vis")


def _interrupt_second_frame(monkeypatch, interrupt) -> None:
    real, calls = exchange._write_synced, []

    def write(path, data):
        calls.append(path)
        if len(calls) == 2:
            interrupt()
        real(path, data)

    monkeypatch.setattr(exchange, "_write_synced", write)


def _last_line(err: str) -> str:
    """The last line of stderr (after a progress bar, if one came up), which must be the
    only one apart from the bar's.
    """
    lines = [x for x in err.replace("\r", "\n").splitlines() if x.strip()]
    assert err.endswith("\n") and not any("Traceback" in x for x in lines), err
    assert all(x.startswith("writing ") for x in lines[:-1]), err
    return lines[-1]


def _raise_keyboard_interrupt():
    raise KeyboardInterrupt


@pytest.mark.parametrize(("interrupt", "status"), [
    (_raise_keyboard_interrupt, 130),  # Ctrl-C
    (lambda: os.kill(os.getpid(), signal.SIGHUP), 129),  # the terminal closed
    (lambda: os.kill(os.getpid(), signal.SIGTERM), 143),
], ids=["SIGINT", "SIGHUP", "SIGTERM"])
def test_an_interrupted_command_says_so_in_one_line(tmp_path, monkeypatch, capsys,
                                                    interrupt, status):
    out = tmp_path / "r.pvd"
    assert main(["export", "--sequence", "--fps", "1", "-o", str(out)]) == 0
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    capsys.readouterr()
    _interrupt_second_frame(monkeypatch, interrupt)
    assert main(["export", "--sequence", "--fps", "2", "-o", str(out)]) == status
    captured = capsys.readouterr()
    assert _last_line(captured.err) == "wrinkle-vis export: interrupted; nothing was changed"
    assert "wrote" not in captured.out
    after = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert after == before  # the old series, and no temporary
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # handlers put back
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_DFL


def _ffmpeg_of(folder: Path) -> list[int]:
    """The processes whose command line names a file in ``folder``."""
    found = []
    for pid in os.listdir("/proc"):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes()
        except (OSError, ValueError):
            continue
        if b"ffmpeg" in cmd and str(folder).encode() in cmd:
            found.append(int(pid))
    return found


def _start_mp4(tmp_path) -> tuple[subprocess.Popen, Path]:
    env = dict(os.environ, WRINKLE_VIS_NO_PROGRESS="1")
    proc = subprocess.Popen([str(CLI), "animate", "--size", "64", "64", "--fps", "60",
                             "-o", str(tmp_path / "a.mp4")], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not _ffmpeg_of(tmp_path):  # wait until ffmpeg writes the temporary
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            pytest.fail(f"animate did not start ffmpeg: {proc.communicate()[1][-500:]}")
        time.sleep(0.05)
    return proc, tmp_path / "a.mp4"


def _gone(pids: list[int], wait_s: float = 5.0) -> bool:
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        if not any(Path(f"/proc/{pid}").exists() and
                   "zombie" not in _state(pid) for pid in pids):
            return True
        time.sleep(0.05)
    return False


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/status").read_text().lower()
    except OSError:
        return "zombie"


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigterm_during_an_mp4_stops_ffmpeg_and_leaves_nothing(tmp_path):
    (tmp_path / "a.mp4").write_bytes(b"old")
    proc, out = _start_mp4(tmp_path)
    ffmpeg = _ffmpeg_of(tmp_path)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err.decode()[-2000:]
    assert err.decode().splitlines()[-1] == \
        "wrinkle-vis animate: interrupted; nothing was changed"
    assert "Traceback" not in err.decode()
    assert _gone(ffmpeg)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mp4"]
    assert out.read_bytes() == b"old"


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_kill_9_during_an_mp4_takes_ffmpeg_along_and_the_next_write_cleans_up(tmp_path):
    proc, out = _start_mp4(tmp_path)
    ffmpeg = _ffmpeg_of(tmp_path)
    for pid in ffmpeg:  # stopped, it would outlive its parent (not drain and exit)
        os.kill(pid, signal.SIGSTOP)
    proc.kill()
    proc.communicate(timeout=60)
    try:
        assert _gone(ffmpeg)  # PR_SET_PDEATHSIG: killed with its parent
    finally:
        for pid in _ffmpeg_of(tmp_path):
            os.kill(pid, signal.SIGKILL)
    left = [p.name for p in tmp_path.iterdir()]
    assert len(left) == 1 and left[0].startswith(f".a.mp4.{proc.pid}-")
    assert clean_stale(tmp_path) == left  # what the next write does first
    assert list(tmp_path.iterdir()) == []


def test_an_interrupt_swallowed_on_its_way_still_changes_nothing(tmp_path, monkeypatch,
                                                                 capsys):
    """As when VTK catches the exception a signal handler raised inside one of its calls."""
    out = tmp_path / "r.pvd"
    assert main(["export", "--sequence", "--fps", "1", "-o", str(out)]) == 0
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    capsys.readouterr()

    def swallowed():
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.1)  # the handler runs here and raises
        except BaseException:
            pass

    _interrupt_second_frame(monkeypatch, swallowed)
    assert main(["export", "--sequence", "--fps", "2", "-o", str(out)]) == 143
    assert _last_line(capsys.readouterr().err) == \
        "wrinkle-vis export: interrupted; nothing was changed"
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
    assert main(["export", "--sequence", "--fps", "2", "-o", str(out)]) == 0  # forgotten
