"""A symbolic link that another user planted does not redirect a write.

A link is written through only if it belongs to the current user or to the owner of the
folder it lies in (the kernel's protected-symlinks rule, applied to the path a writer
renames onto, which the kernel never sees). The links are made by root and given to
another user with ``os.lchown``.
"""

import os
import stat
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.app.recovery import Recovery
from wrinkle_vis.cli import main
from wrinkle_vis.core.files import OutputPathError, resolve_output
from wrinkle_vis.plotting.bake import BakedMaps, save_bake
from wrinkle_vis.plotting.writers import save_animation, save_image, save_mesh

pytestmark = pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0,
                                reason="making a link of another user needs root")
NOBODY = 65534
SECRET = b"root:$6$x:1:0:9::::\n"

WRITERS = {
    "layout": lambda p: wv.save_layout(wv.Layout(name="x"), p),
    "vtp": lambda p: save_mesh(pv.Sphere(), p),
    "ply": lambda p: save_mesh(pv.Sphere(), p),
    "vtm": lambda p: save_mesh(pv.MultiBlock({"skin": pv.Sphere()}), p),
    "png": lambda p: save_image(np.zeros((20, 30, 3), np.uint8), p),
    "gif": lambda p: save_animation((np.zeros((16, 16, 3), np.uint8) for _ in range(2)), p, 5),
}
SUFFIX = {"layout": ".json"}


@pytest.fixture
def shared(tmp_path):
    """A sticky world-writable folder (as /tmp) and a root-only file outside it."""
    folder = tmp_path / "s"
    folder.mkdir()
    folder.chmod(0o1777)
    secret = tmp_path / "shadowlike"
    secret.write_bytes(SECRET)
    secret.chmod(0o640)
    return folder, secret


def _plant(link: Path, target: Path, uid: int = NOBODY) -> Path:
    link.symlink_to(target)
    os.lchown(link, uid, uid)
    return link


@pytest.mark.parametrize("kind", list(WRITERS))
def test_a_link_planted_by_another_user_is_not_written_through(shared, kind):
    folder, secret = shared
    link = _plant(folder / f"out{SUFFIX.get(kind, '.' + kind)}", secret)
    with pytest.raises(OutputPathError, match="belongs to another user") as info:
        WRITERS[kind](link)
    assert "\n" not in str(info.value) and "remove the link or write somewhere else" in \
        str(info.value)
    assert secret.read_bytes() == SECRET and stat.S_IMODE(secret.stat().st_mode) == 0o640
    assert link.is_symlink() and sorted(p.name for p in folder.iterdir()) == [link.name]


def test_the_cli_refuses_a_planted_link_in_one_line(shared, capsys):
    folder, secret = shared
    link = _plant(folder / "out.vtp", secret)
    assert main(["export", "-o", str(link)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "belongs to another user (uid 65534)" in err, err
    assert secret.read_bytes() == SECRET


def test_a_planted_link_on_the_way_is_refused_too(shared, tmp_path):
    folder, secret = shared
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "out.png").write_bytes(b"mine")
    _plant(folder / "dir", elsewhere)
    with pytest.raises(OutputPathError, match="belongs to another user"):
        save_image(np.zeros((20, 30, 3), np.uint8), folder / "dir" / "out.png")
    assert (elsewhere / "out.png").read_bytes() == b"mine"
    with pytest.raises(OutputPathError, match="belongs to another user"):  # bake's folder
        save_bake(BakedMaps({"displacement.png": np.zeros((4, 4), np.uint16)}),
                  folder / "dir" / "maps")
    assert sorted(p.name for p in elsewhere.iterdir()) == ["out.png"]


def test_the_autosave_in_a_shared_recovery_folder_is_not_redirected(shared):
    folder, secret = shared
    rec = Recovery(folder)
    _plant(rec.path, secret)
    with pytest.raises(OutputPathError, match="belongs to another user"):
        rec.save(wv.Layout(), None, 4500)
    assert secret.read_bytes() == SECRET


def test_links_of_the_user_or_the_folders_owner_are_written_through(shared, tmp_path):
    folder, _ = shared
    target = tmp_path / "target.png"
    target.write_bytes(b"old")
    mine = _plant(folder / "mine.png", target, uid=os.geteuid())
    save_image(np.zeros((20, 30, 3), np.uint8), mine)
    assert target.read_bytes()[:4] == b"\x89PNG"
    theirs = tmp_path / "theirs"  # a folder of another user, and that user's link in it
    theirs.mkdir()
    os.chown(theirs, NOBODY, NOBODY)
    target.write_bytes(b"old")
    link = _plant(theirs / "out.png", target)
    assert resolve_output(link) == target
    save_image(np.zeros((20, 30, 3), np.uint8), link)
    assert target.read_bytes()[:4] == b"\x89PNG"


def test_resolution_follows_links_as_the_kernel_does(tmp_path):
    (tmp_path / "a" / "b").mkdir(parents=True)
    (tmp_path / "up").symlink_to("a/b")
    (tmp_path / "a" / "b" / "rel").symlink_to("../x.png")
    assert resolve_output(tmp_path / "up" / "rel") == tmp_path / "a" / "x.png"
    assert resolve_output(tmp_path / "up" / ".." / "new.png") == tmp_path / "a" / "new.png"
    assert resolve_output(tmp_path / "up" / "new.png") == Path(
        os.path.realpath(tmp_path / "up")) / "new.png"
    (tmp_path / "loop").symlink_to("loop")
    with pytest.raises(OutputPathError, match="too many symbolic links"):
        resolve_output(tmp_path / "loop")


def test_the_app_says_so_when_its_autosave_meets_a_planted_link(shared, make_window,
                                                                 wv_face):
    from wrinkle_vis.app.session import Session

    folder, secret = shared
    w = make_window(Session(wv_face), Recovery(folder))
    _plant(w.recovery.path, secret)
    w.session.dirty = True
    w.autosave()  # no exception out of the Qt slot
    assert "Autosave failed" in w.statusBar().currentMessage()
    assert "belongs to another user" in w.statusBar().currentMessage()
    assert secret.read_bytes() == SECRET
