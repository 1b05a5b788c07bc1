"""Every writer is atomic: a temporary file beside the target, checked, then renamed.

Saving over a file keeps its permissions and writes through a symbolic link; a failure
(a full disk, a bad target) is one line, leaves the old file intact and no temporary file.
"""

import errno
import os
import stat
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import meshio
import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.app.recovery import Recovery
from wrinkle_vis.cli import main
from wrinkle_vis.core.files import (
    OutputPathError,
    WriteError,
    atomic_output,
    atomic_write_bytes,
    check_output,
)
from wrinkle_vis.plotting.writers import (
    ply_properties,
    save_animation,
    save_image,
    save_mesh,
)

CLI = Path(sys.executable).with_name("wrinkle-vis")


def _leftovers(folder: Path, keep=()) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


def _pieces(folder: Path) -> list[str]:
    """The files in ``folder``'s one version folder (``v<pid>-<hex>``)."""
    (version,) = folder.iterdir()
    assert version.is_dir() and version.name.startswith("v")
    return sorted(p.name for p in version.iterdir())


def _sphere() -> pv.PolyData:
    mesh = pv.Sphere(theta_resolution=12, phi_resolution=12)
    mesh.point_data.clear()
    mesh.point_data["W"] = np.linspace(-1, 1, mesh.n_points)
    mesh.point_data["corrugator_L.eps"] = np.where(mesh.points[:, 0] > 0, np.nan, 0.5)
    mesh.point_data["deformation"] = np.random.default_rng(0).random((mesh.n_points, 3))
    return mesh


WRITERS = {
    "layout": lambda p: wv.save_layout(wv.Layout(name="x"), p),
    "vtp": lambda p: save_mesh(_sphere(), p),
    "vtk": lambda p: save_mesh(_sphere(), p),
    "ply": lambda p: save_mesh(_sphere(), p),
    "vtm": lambda p: save_mesh(pv.MultiBlock({"skin": _sphere()}), p),
    "png": lambda p: save_image(np.zeros((20, 30, 3), np.uint8), p),
    "gif": lambda p: save_animation((np.zeros((16, 16, 3), np.uint8) for _ in range(3)), p, 5),
}
SUFFIX = {"layout": ".json"}


def _target(tmp_path, kind) -> Path:
    return tmp_path / f"out{SUFFIX.get(kind, '.' + kind)}"


# ---------------------------------------------------------------------- permissions, links
@pytest.mark.parametrize("kind", list(WRITERS))
def test_saving_over_a_file_keeps_its_permissions(tmp_path, kind):
    target = _target(tmp_path, kind)
    target.write_bytes(b"old")
    target.chmod(0o640)
    WRITERS[kind](target)
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    assert target.read_bytes() != b"old"


@pytest.mark.parametrize("kind", list(WRITERS))
def test_a_new_file_gets_the_umask_permissions(tmp_path, kind):
    old = os.umask(0o027)
    try:
        WRITERS[kind](_target(tmp_path, kind))
    finally:
        os.umask(old)
    assert stat.S_IMODE(_target(tmp_path, kind).stat().st_mode) == 0o640  # not 0600


@pytest.mark.parametrize("kind", list(WRITERS))
def test_saving_through_a_symbolic_link_writes_its_target(tmp_path, kind):
    real_dir = tmp_path / "real"
    real_dir.mkdir()
    target = _target(real_dir, kind)
    target.write_bytes(b"old")
    link = _target(tmp_path, kind)
    link.symlink_to(target)
    WRITERS[kind](link)
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_bytes() != b"old"
    assert _leftovers(tmp_path) == sorted(["real", link.name])


def test_recovery_file_keeps_its_permissions(tmp_path):
    rec = Recovery(tmp_path)
    rec.save(wv.Layout(), None, 4500).chmod(0o644)
    rec.save(wv.Layout(name="again"), None, 4500)
    assert stat.S_IMODE(rec.path.stat().st_mode) == 0o644
    assert Recovery.load(rec.path).layout.name == "again"


# ---------------------------------------------------------------------- failures
@pytest.mark.parametrize("kind", list(WRITERS))
def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, kind,
                                                                    monkeypatch):
    target = _target(tmp_path, kind)
    target.write_bytes(b"old")
    import builtins

    real_open = builtins.open

    class Full:  # a file object whose writes fail as on a full disk
        def __init__(self, fh):
            self._fh = fh

        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

        def __getattr__(self, name):
            return getattr(self._fh, name)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self._fh.close()

    def full_open(file, mode="r", *args, **kwargs):
        fh = real_open(file, mode, *args, **kwargs)
        return Full(fh) if "w" in mode and ".tmp" in str(file) else fh

    monkeypatch.setattr(builtins, "open", full_open)
    with pytest.raises(WriteError) as info:
        WRITERS[kind](target)
    message = str(info.value)
    assert "\n" not in message and "no space left" in message and str(target) in message
    monkeypatch.undo()
    assert target.read_bytes() == b"old"
    assert _leftovers(tmp_path) == [target.name]


def test_a_file_that_does_not_read_back_is_not_renamed(tmp_path):
    target = tmp_path / "a.bin"
    target.write_bytes(b"old")

    def reject(tmp):
        raise ValueError("3 points instead of 4")

    with pytest.raises(WriteError, match="does not read back.*3 points instead of 4"):
        atomic_write_bytes(target, b"new", check=reject)
    assert target.read_bytes() == b"old" and _leftovers(tmp_path) == ["a.bin"]


def test_a_writer_that_writes_nothing_is_an_error(tmp_path):
    with pytest.raises(WriteError, match="wrote nothing"), atomic_output(tmp_path / "e.mp4"):
        pass
    assert _leftovers(tmp_path) == []


def test_an_interrupted_write_removes_its_temporary_file(tmp_path):
    with pytest.raises(KeyboardInterrupt), atomic_output(tmp_path / "k.gif") as tmp:
        tmp.write_bytes(b"half")
        raise KeyboardInterrupt
    assert _leftovers(tmp_path) == []


@contextmanager
def _read_only_folder(tmp_path):
    """A folder writes fail in: a read-only tmpfs as root, else a folder without write
    permission.
    """
    folder = tmp_path / "ro"
    folder.mkdir()
    if os.geteuid() == 0:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs",
                               str(folder)], capture_output=True)
        if done.returncode != 0:
            pytest.skip(f"cannot mount a read-only tmpfs: {done.stderr.decode().strip()}")
        try:
            yield folder
        finally:
            subprocess.run(["umount", str(folder)], check=False)
    else:
        folder.chmod(0o555)
        try:
            yield folder
        finally:
            folder.chmod(0o755)


BAD_TARGETS = [
    ("folder", lambda t: t, ".png", "is a folder; give a file name inside it"),
    ("missing folder", lambda t: t / "nope" / "a.png", ".png",
     "does not exist; create it first"),
    ("not a folder", lambda t: t / "file.txt" / "a.png", ".png", "is not a folder"),
    ("no extension", lambda t: t / "noext", ".png", "has no extension; name it with .png"),
    ("wrong extension", lambda t: t / "a.stl", ".vtp", "unsupported extension '.stl'"),
]


@pytest.mark.parametrize(("case", "where", "suffix", "message"), BAD_TARGETS,
                         ids=[b[0] for b in BAD_TARGETS])
def test_bad_targets_are_refused_before_any_work(tmp_path, case, where, suffix, message):
    (tmp_path / "file.txt").write_text("x")
    with pytest.raises(OutputPathError, match=message) as info:
        check_output(where(tmp_path), (suffix,))
    assert "\n" not in str(info.value)


def test_a_read_only_folder_is_refused(tmp_path):
    with _read_only_folder(tmp_path) as folder:
        with pytest.raises(OutputPathError, match="read-only|not writable"):
            check_output(folder / "a.png", (".png",))


# ---------------------------------------------------------------------- formats
def test_ply_keeps_every_point_array(tmp_path):
    mesh = _sphere()
    written = save_mesh(mesh, tmp_path / "s.ply")
    assert written.summary == (f"{mesh.n_points} points, {mesh.n_cells} triangles, "
                               "3 point arrays (5 vertex properties)")
    back = meshio.read(tmp_path / "s.ply")
    np.testing.assert_array_equal(back.points, mesh.points)
    np.testing.assert_array_equal(back.cells_dict["triangle"],
                                  mesh.faces.reshape(-1, 4)[:, 1:])
    props = ply_properties(mesh)
    assert set(back.point_data) == set(props) == {
        "W", "corrugator_L.eps", "deformation_x", "deformation_y", "deformation_z"}
    for key, values in props.items():
        np.testing.assert_array_equal(back.point_data[key], values)  # NaN where NaN


def test_cli_ply_export_of_a_face_keeps_every_field(tmp_path, capsys):
    out = tmp_path / "fear.ply"
    assert main(["export", "-e", "fear", "-o", str(out)]) == 0
    state = wv.datasets.load_face().evaluate("fear")
    mesh = state.to_polydata()
    props = ply_properties(mesh)
    assert capsys.readouterr().out.strip() == (
        f"wrote {out}: {mesh.n_points} points, {mesh.n_cells} triangles, "
        f"{len(mesh.point_data)} point arrays ({len(props)} vertex properties)")
    back = meshio.read(out)
    assert set(back.point_data) == set(props)
    for key, values in props.items():
        np.testing.assert_array_equal(back.point_data[key], values)
    np.testing.assert_array_equal(back.point_data["W"], state.W)
    np.testing.assert_array_equal(back.point_data["corrugator_L__eps"],
                                  state.fields["corrugator_L"]["eps"])


@pytest.mark.parametrize("suffix", [".vtp", ".vtk"])
def test_vtk_formats_read_back_with_every_array(tmp_path, suffix):
    mesh = _sphere()
    save_mesh(mesh, tmp_path / f"s{suffix}")
    back = pv.read(tmp_path / f"s{suffix}")
    for key in mesh.point_data:
        np.testing.assert_array_equal(back[key], mesh[key])


def test_vtm_replaces_its_pieces_folder_as_a_whole(tmp_path):
    blocks = pv.MultiBlock({"skin": _sphere(), "muscles": pv.MultiBlock(
        {"a": pv.Cube(), "b": pv.Cone(), "c": pv.Sphere()})})
    save_mesh(blocks, tmp_path / "f.vtm")
    assert _pieces(tmp_path / "f") == ["f_0.vtp", "f_1.vtp", "f_2.vtp", "f_3.vtp"]
    save_mesh(pv.MultiBlock({"skin": _sphere()}), tmp_path / "f.vtm")
    assert _pieces(tmp_path / "f") == ["f_0.vtp"]  # the old version is gone
    back = pv.read(tmp_path / "f.vtm")
    assert back.keys() == ["skin"] and _leftovers(tmp_path) == ["f", "f.vtm"]


def test_vtm_refuses_a_pieces_folder_with_other_files(tmp_path):
    (tmp_path / "f").mkdir()
    (tmp_path / "f" / "thesis.tex").write_text("mine")
    with pytest.raises(OutputPathError, match="holds other files"):
        save_mesh(pv.MultiBlock({"skin": _sphere()}), tmp_path / "f.vtm")
    assert (tmp_path / "f" / "thesis.tex").read_text() == "mine"


def test_animation_frames_are_streamed_to_the_file(tmp_path):
    """Each frame is on disk before the next is asked for: none is kept in memory."""
    sizes = []

    def frames():
        for i in range(6):
            tmp = [p for p in tmp_path.iterdir() if p.name.startswith(".a.gif.")]
            sizes.append(tmp[0].stat().st_size if tmp else None)
            yield np.full((32, 40, 3), 40 * i, np.uint8)

    written = save_animation(frames(), tmp_path / "a.gif", 4)
    assert written.summary == "6 frames"
    assert sizes[0] == 0 and all(b > a for a, b in zip(sizes[1:], sizes[2:], strict=False))
    import imageio.v3 as iio

    back = iio.imread(tmp_path / "a.gif", index=None)
    assert back.shape == (6, 32, 40, 3) and [int(f[0, 0, 0]) for f in back] == [
        0, 40, 80, 120, 160, 200]


def _striped_frames(count: int = 3, h: int = 48, w: int = 40) -> list[np.ndarray]:
    """Frames whose every row differs (fewer than 256 colours, so quantizing is exact): a
    GIF whose rows come back in another order cannot decode to them."""
    rows = np.arange(h)[:, None]
    cols = np.arange(w)[None, :]
    out = []
    for i in range(count):
        frame = np.zeros((h, w, 3), np.uint8)
        frame[..., 0] = (5 * rows + 30 * i) % 250
        frame[..., 1] = np.where(cols < w // 2, 200, 60 + 10 * i)
        frame[..., 2] = 120
        out.append(frame)
    return out


def test_gif_frames_decode_to_the_frames_rendered(tmp_path):
    """Issue 32: Pillow wrote its LZW data interlaced while the descriptor said it was not, so
    every decoder put the rows out of order. Two independent readers get the frames back."""
    from PIL import Image, ImageSequence

    frames = _striped_frames()
    save_animation(iter(frames), tmp_path / "s.gif", 5)
    with Image.open(tmp_path / "s.gif") as im:
        back = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]
    assert len(back) == len(frames)
    for got, want in zip(back, frames, strict=True):
        np.testing.assert_array_equal(got, want)
    import imageio.v3 as iio

    np.testing.assert_array_equal(iio.imread(tmp_path / "s.gif", index=None)[..., :3],
                                  np.stack(frames))


# ---------------------------------------------------------------------- a full disk
@contextmanager
def _small_tmpfs(folder: Path, size: str = "64k"):
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root")
    folder.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs",
                           str(folder)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {done.stderr.decode().strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], check=False)


@pytest.mark.parametrize("suffix", [".vtp", ".vtk", ".ply", ".vtm"])
def test_export_onto_a_full_disk_fails_in_one_line_with_the_old_file_intact(
        tmp_path, suffix, capsys):
    with _small_tmpfs(tmp_path / "small") as small:
        target = small / f"face{suffix}"
        target.write_bytes(b"the old export")
        assert main(["export", "-e", "surprise", "-o", str(target)]) == 2
        out, err = capsys.readouterr()
        assert out == "" and err.count("\n") == 1
        assert err.startswith("wrinkle-vis export: could not write") and "no space left" in err
        assert target.read_bytes() == b"the old export"
        assert _leftovers(small) == [target.name]


def test_export_onto_a_full_disk_in_a_real_process(tmp_path):
    """No SIGSEGV, no traceback, no VTK error pages: one line and exit status 2."""
    with _small_tmpfs(tmp_path / "small") as small:
        target = small / "face.vtp"
        target.write_bytes(b"the old export")
        done = subprocess.run([str(CLI), "export", "-e", "surprise", "-o", str(target)],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 2, done.stderr
        assert done.stdout == "" and done.stderr.count("\n") == 1
        assert "no space left on the device" in done.stderr
        assert target.read_bytes() == b"the old export"
        assert _leftovers(small) == [target.name]


@pytest.mark.parametrize("argv", [["render", "--size", "32", "32"], ["export"],
                                  ["animate", "--fps", "1"], ["figure", "fig11"]])
def test_the_cli_refuses_a_read_only_folder_in_one_line(tmp_path, argv, capsys):
    suffix = {"render": ".png", "export": ".vtp", "animate": ".gif", "figure": ".png"}
    with _read_only_folder(tmp_path) as folder:
        out = folder / f"x{suffix[argv[0]]}"
        assert main([*argv, "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--output folder '{folder}'" in err
        assert "read-only" in err or "not writable" in err
        assert not out.exists()


def test_the_library_renderers_write_their_png_atomically(tmp_path, wv_face):
    from wrinkle_vis.plotting import figure_expressions, figure_refinement, render_field

    target = tmp_path / "w.png"
    target.write_bytes(b"old")
    target.chmod(0o640)
    image = render_field(wv_face, "surprise", size=(64, 48), filename=target)
    assert stat.S_IMODE(target.stat().st_mode) == 0o640 and _leftovers(tmp_path) == ["w.png"]
    import imageio.v3 as iio

    np.testing.assert_array_equal(iio.imread(target)[..., :3], image[..., :3])
    for call in (lambda p: render_field(wv_face, filename=p),
                 lambda p: figure_expressions(wv_face, filename=p),
                 lambda p: figure_refinement(wv_face, p)):
        with pytest.raises(OutputPathError, match="does not exist"):
            call(tmp_path / "missing" / "x.png")  # refused before rendering
        with pytest.raises(OutputPathError, match="unsupported extension '.jpg'"):
            call(tmp_path / "x.jpg")
