"""Outputs of several files are replaced as a whole, even by a kill.

A writer runs in a forked child that SIGKILLs itself just before its n-th rename, exchange,
unlink or rmdir, for every n until it runs to the end; after each kill the output must be
the old one or the new one entirely (never mixed, never missing), and the next write must
leave nothing of the killed one behind.
"""

import json
import os
import re
import signal
import time
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
import wrinkle_vis.core.files as files
from wrinkle_vis.plotting.bake import BakedMaps, save_bake
from wrinkle_vis.plotting.exchange import save_sequence
from wrinkle_vis.plotting.writers import save_mesh

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
OPS = ("rename", "replace", "unlink", "rmdir")


def _killed_at(n: int, write) -> bool:
    """Run ``write()`` in a forked child killed (SIGKILL) just before its ``n``-th file
    operation; True if it was killed, False if it ran to the end.
    """
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        try:
            count = [0]

            def hook(fn):
                def counted(*args, **kwargs):
                    count[0] += 1
                    if count[0] == n:
                        os.kill(os.getpid(), signal.SIGKILL)
                    return fn(*args, **kwargs)
                return counted

            for name in OPS:
                setattr(os, name, hook(getattr(os, name)))
            if hasattr(files, "exchange"):
                files.exchange = hook(files.exchange)
            write()
            os._exit(0)
        except BaseException:
            os._exit(3)
    _, status = os.waitpid(pid, 0)
    if os.WIFEXITED(status):
        assert os.WEXITSTATUS(status) == 0, "the writer failed in the child"
        return False
    assert os.WTERMSIG(status) == signal.SIGKILL
    return True


def _every_kill(tmp_path, write_old, write_new, state, cleaned_up, limit=200):
    """Kill ``write_new`` at each point in turn (``write_old`` first each time): ``state()``
    must say "old" or "new" after every kill, and after the next write the folder holds
    only ``cleaned_up()``. Returns the states seen.
    """
    seen = []
    for n in range(1, limit):
        write_old()
        killed = _killed_at(n, write_new)
        seen.append(state())
        write_new()  # the next run
        assert state() == "new"
        assert cleaned_up(), sorted(p.name for p in tmp_path.iterdir())
        if not killed:
            break
    else:
        pytest.fail(f"the writer was still being killed after {limit} points")
    assert set(seen) <= {"old", "new"}, seen
    assert seen[0] == "old" and seen[-1] == "new"
    return seen


@pytest.fixture(scope="module")
def states():
    face = wv.datasets.load_face(n_triangles=500)
    ramp = face.expressions["frown"]
    return {t: face.evaluate(ramp.at(t)) for t in (0.5, 1.0, 2.0)}


def _pvd_state(index: Path, old: list[float], new: list[float]) -> str:
    text = index.read_text()
    entries = re.findall(r'timestep="([^"]+)".*?file="([^"]+)"', text)
    times = [float(t) for t, _ in entries]
    for t, rel in entries:  # every frame the index names is there, with its time
        mesh = pv.read(index.parent / rel)
        assert mesh.field_data["TimeValue"][0] == float(t)
    return {tuple(old): "old", tuple(new): "new"}[tuple(times)]


def test_a_pvd_series_is_old_or_new_after_a_kill_at_any_point(tmp_path, states):
    out, old, new = tmp_path / "r.pvd", [0.5, 1.0], [2.0]
    seen = _every_kill(
        tmp_path,
        lambda: save_sequence([states[t] for t in old], old, out),
        lambda: save_sequence([states[t] for t in new], new, out),
        lambda: _pvd_state(out, old, new),
        lambda: sorted(p.name for p in tmp_path.iterdir()) == ["r", "r.pvd"]
        and len(list((tmp_path / "r").iterdir())) == 1)
    assert len(seen) > 5, len(seen)  # the rename points, and those of the tidying


@pytest.mark.parametrize("suffix", [".obj", ".ply"])
def test_numbered_frames_are_old_or_new_after_a_kill_at_any_point(tmp_path, states,
                                                                  suffix):
    out, old, new = tmp_path / f"f_####{suffix}", [0.5, 1.0], [2.0]

    def state() -> str:
        frames = sorted((tmp_path / "f").glob("f_*")) or sorted(tmp_path.glob("f_????.*"))
        n = len(frames)
        assert [p.name for p in frames] == [f"f_{i:04d}{suffix}" for i in range(n)]
        times = old if n == 2 else new
        for frame, t in zip(frames, times, strict=True):  # each frame of that run
            np.testing.assert_allclose(pv.read(frame).points, states[t].points, atol=1e-6)
        return {2: "old", 1: "new"}[n]

    _every_kill(tmp_path,
                lambda: save_sequence([states[t] for t in old], old, out),
                lambda: save_sequence([states[t] for t in new], new, out),
                state,
                lambda: sorted(p.name for p in tmp_path.iterdir()) == ["f"])


def test_a_vtm_is_old_or_new_after_a_kill_at_any_point(tmp_path):
    out = tmp_path / "m.vtm"
    old = pv.MultiBlock({"a": pv.Sphere(), "b": pv.Cube()})
    new = pv.MultiBlock({"c": pv.Cone()})

    def state() -> str:
        text = out.read_text()
        for rel in re.findall(r'file="([^"]+)"', text):
            assert (tmp_path / rel).is_file(), rel
        keys = pv.read(out).keys()
        return {("a", "b"): "old", ("c",): "new"}[tuple(keys)]

    _every_kill(tmp_path, lambda: save_mesh(old, out), lambda: save_mesh(new, out), state,
                lambda: sorted(p.name for p in tmp_path.iterdir()) == ["m", "m.vtm"]
                and len(list((tmp_path / "m").iterdir())) == 1)


def _maps(value: int, fields: tuple[str, ...]) -> BakedMaps:
    images = {"displacement.png": np.full((4, 4), value, np.uint16)}
    images.update({f"field_{f}.png": np.full((4, 4, 4), value % 256, np.uint8)
                   for f in fields})
    return BakedMaps(images, {"displacement.json": {"value": value}})


def _bake_state(out: Path) -> str:
    names = sorted(p.name for p in out.iterdir())
    value = json.loads((out / "displacement.json").read_text())["value"]
    expected = {1: ["displacement.json", "displacement.png", "field_W.png", "field_x.png"],
                2: ["displacement.json", "displacement.png", "field_y.png"]}[value]
    assert names == expected
    from PIL import Image

    with Image.open(out / "displacement.png") as im:
        assert np.asarray(im).max() == value
    return {1: "old", 2: "new"}[value]


def test_bake_is_old_or_new_after_a_kill_at_any_point(tmp_path):
    out = tmp_path / "maps"
    _every_kill(tmp_path, lambda: save_bake(_maps(1, ("W", "x")), out),
                lambda: save_bake(_maps(2, ("y",)), out), lambda: _bake_state(out),
                lambda: sorted(p.name for p in tmp_path.iterdir()) == ["maps"])


def test_without_an_exchange_a_killed_swap_is_put_right_by_the_next_run(tmp_path,
                                                                       monkeypatch):
    """Where renameat2 is missing the old folder is moved aside first: a kill then can
    leave the place empty, and the next write puts the old folder back before its own.
    """
    monkeypatch.setattr(files, "_RENAMEAT2", None)
    out = tmp_path / "maps"
    seen = []
    for n in range(1, 100):
        save_bake(_maps(1, ("W", "x")), out)
        killed = _killed_at(n, lambda: save_bake(_maps(2, ("y",)), out))
        files.clean_stale(tmp_path)  # what the next run does first
        seen.append(_bake_state(out))
        assert sorted(p.name for p in tmp_path.iterdir()) == ["maps"]
        if not killed:
            break
    assert seen[0] == "old" and seen[-1] == "new" and set(seen) == {"old", "new"}


def test_stale_temporaries_of_dead_processes_go_and_live_ones_stay(tmp_path):
    dead = os.fork()
    if dead == 0:
        os._exit(0)
    os.waitpid(dead, 0)
    live, here = os.getppid(), files.HOST_TAG
    away = "0" * 6 if here != "0" * 6 else "1" * 6  # another machine or container
    names = {f".a.gif.{dead}-{here}.abcd_123.tmp.gif": "dead",
             f".r.{dead}-{here}.x1y2z3w4.tmp": "dead",
             f".a.gif.{live}-{here}.abcd_123.tmp.gif": "live",
             f".maps.old.{live}-{here}.q1w2e3r4": "live",
             f".b.gif.{dead}-{away}.abcd_123.tmp.gif": "elsewhere, fresh",
             f".c.gif.{dead}-{away}.abcd_123.tmp.gif": "elsewhere, two days old",
             ".notes.txt": "not ours", "a.gif": "not ours", f".a.gif.{dead}.tmp": "not ours"}
    for name in names:
        (tmp_path / name).write_text("x")
    two_days_ago = time.time() - 2 * 86400
    os.utime(tmp_path / f".c.gif.{dead}-{away}.abcd_123.tmp.gif", (two_days_ago,) * 2)
    files.clean_stale(tmp_path)
    left = {p.name for p in tmp_path.iterdir()}
    assert left == {n for n, why in names.items() if why not in ("dead", "elsewhere, two "
                                                                 "days old")}


def test_a_killed_move_aside_is_put_back_when_its_place_is_empty(tmp_path):
    dead = os.fork()
    if dead == 0:
        os._exit(0)
    os.waitpid(dead, 0)
    aside = tmp_path / f".maps.old.{dead}-{files.HOST_TAG}.a1b2c3d4" / "maps"
    aside.mkdir(parents=True)
    (aside / "displacement.png").write_bytes(b"old")
    assert files.clean_stale(tmp_path) == [aside.parent.name]
    assert (tmp_path / "maps" / "displacement.png").read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["maps"]


def test_temporaries_from_before_the_pid_was_in_their_names_go_when_old(tmp_path):
    fresh, old = tmp_path / ".r.abcd1234.tmp", tmp_path / ".a.gif.wxyz9876.tmp.gif"
    fresh.mkdir()
    old.write_text("x")
    hour_ago = os.path.getmtime(old) - 3600
    os.utime(old, (hour_ago, hour_ago))
    files.clean_stale(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [fresh.name]


# ---------------------------------------------------------------------- cache, recovery
def test_a_full_cache_disk_leaves_no_partial_entry(tmp_path, monkeypatch):
    import errno

    from wrinkle_vis.datasets._cache import cached

    monkeypatch.setenv("WRINKLE_VIS_CACHE", str(tmp_path / "cache"))
    def full(file, **arrays):  # part of an entry, then the disk is full
        if isinstance(file, (str, os.PathLike)):
            Path(file).write_bytes(b"PK\x03\x04 part")
        else:
            file.write(b"PK\x03\x04 part")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savez", full)
    arrays = cached("skin", (1,), lambda: {"a": np.arange(5)})
    np.testing.assert_array_equal(arrays["a"], np.arange(5))  # still built
    assert list((tmp_path / "cache").iterdir()) == []


def test_a_cache_entry_is_synced_before_it_is_renamed_into_place(tmp_path, monkeypatch):
    from wrinkle_vis.datasets._cache import cached

    monkeypatch.setenv("WRINKLE_VIS_CACHE", str(tmp_path / "cache"))
    synced, real_fsync, real_replace = [], os.fsync, os.replace

    def fsync(fd):
        synced.append(os.readlink(f"/proc/self/fd/{fd}"))
        real_fsync(fd)

    def replace(src, dst):
        assert str(src) in synced, "renamed before it was synced"
        real_replace(src, dst)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    cached("skin", (2,), lambda: {"a": np.arange(5)})
    (entry,) = (tmp_path / "cache").iterdir()
    with np.load(entry) as data:
        np.testing.assert_array_equal(data["a"], np.arange(5))


def test_the_recovery_folder_and_files_are_private(tmp_path):
    from wrinkle_vis.app.recovery import Recovery

    old = os.umask(0o022)
    try:
        path = Recovery(tmp_path / "state" / "recovery").save(wv.Layout(), None, 4500)
    finally:
        os.umask(old)
    assert oct(path.parent.stat().st_mode & 0o777) == oct(0o700)
    assert oct(path.stat().st_mode & 0o777) == oct(0o600)


def test_a_series_written_before_version_folders_is_replaced_whole(tmp_path, states):
    """An index over pieces directly in its folder (as written before versions)."""
    out, folder = tmp_path / "r.pvd", tmp_path / "r"
    folder.mkdir()
    pv.Sphere().save(folder / "r_0000.vtp")
    out.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                   '<Collection>\n<DataSet timestep="0" file="r/r_0000.vtp"/>\n'
                   '</Collection>\n</VTKFile>\n')
    save_sequence([states[2.0]], [2.0], out)
    assert _pvd_state(out, [0.0], [2.0]) == "new"
    (version,) = folder.iterdir()  # the old piece is gone
    assert [p.name for p in version.iterdir()] == ["r_0000.vtp"]
