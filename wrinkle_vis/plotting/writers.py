"""Writing meshes, images and animations atomically (no Qt).

Every writer here checks its target before any work (:func:`check_target`), builds the file
in memory or in a temporary file beside the target, checks it (meshes are read back), and
renames it over the target (:func:`wrinkle_vis.core.files.atomic_output`): a failure (a full
disk, a read-only folder) raises a one-line :class:`~wrinkle_vis.core.files.WriteError`
and leaves the old file as it was. VTK's own file writers are not used: on a full disk they
print pages of errors, leave a truncated file and can crash the process; here VTK serializes
to memory and Python writes, so every I/O error is an exception.

Formats
-------
``.vtp``, ``.vtk``
    The skin with every point array and its field data (VTK XML with zlib-compressed
    base64 data, or legacy binary VTK). Neither is a format meshio reads (it reads no
    PolyData); write ``.vtu`` for it.
``.vtu``
    The same as an unstructured grid of triangles (VTK XML), which meshio reads too; its
    field data keeps only the numeric arrays (meshio cannot read VTK string arrays).
``.obj``
    Wavefront OBJ: positions, vertex normals (the ``Normals`` point array, else computed)
    and triangles; the unit in a comment.
``.stl``
    Binary STL: triangles with their facet normals; the unit in the 80-byte header (STL
    has no other place for it).
``.ply``
    Binary little-endian PLY: ``x y z`` and one vertex property per component of every
    point array (``W``; a vector array ``deformation`` as ``deformation_x``,
    ``deformation_y``, ``deformation_z``), all as ``double`` so values survive exactly,
    and the triangles as ``vertex_indices``. (VTK's PLY writer drops arbitrary arrays.)
``.vtm``
    A multiblock: ``name.vtm`` indexes the pieces written to the folder ``name/`` beside it,
    as ParaView expects, in a version folder of their own (``name/v<pid>-<host>-<hex>/name_0.vtp``,
    ...): the new version goes in, then the index is renamed over the old one, then the old
    version goes, so a kill at any point leaves an index over its own pieces
    (:func:`~wrinkle_vis.core.files.replace_indexed`).
``.png``
    Images; ``.gif`` and ``.mp4`` animations, streamed frame by frame.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pyvista as pv

from ..core.files import (
    OutputPathError,
    WriteError,
    atomic_output,
    atomic_write_bytes,
    check_output,
    new_version,
    replace_folder,
    replace_indexed,
    temp_folder,
    tidy_versions,
    write_error,
)
from ..datasets.meshfile import quiet_read
from .finite import require_finite

__all__ = ["ANIMATION_SUFFIXES", "IMAGE_SUFFIXES", "MESH_SUFFIXES", "Written",
           "check_target", "replace_folder", "save_animation", "save_image", "save_mesh"]

#: Mesh formats :func:`save_mesh` writes (``.vtm`` for a ``MultiBlock``, the others for one
#: ``PolyData``).
MESH_SUFFIXES = (".vtp", ".vtu", ".vtk", ".ply", ".obj", ".stl", ".vtm")
#: Image formats :func:`save_image` writes.
IMAGE_SUFFIXES = (".png",)
#: Animation formats :func:`save_animation` writes.
ANIMATION_SUFFIXES = (".gif", ".mp4")


@dataclass(frozen=True)
class Written:
    """What a writer wrote: the file (symbolic links resolved) and a one-line account."""

    path: Path
    summary: str


def check_target(path: str | os.PathLike, suffixes) -> Path:
    """Check an output path before any work (:func:`~wrinkle_vis.core.files.check_output`);
    for ``.vtm`` and ``.pvd`` also that the folder of their pieces can be replaced.

    Raises
    ------
    OutputPathError
        Naming the problem and the way out.
    """
    real = check_output(path, suffixes)
    if real.suffix.lower() in (".vtm", ".pvd"):
        _check_piece_folder(real)
    return real


# ---------------------------------------------------------------------- meshes
def save_mesh(mesh: pv.PolyData | pv.MultiBlock, path: str | os.PathLike) -> Written:
    """Write ``mesh`` to ``path`` (:data:`MESH_SUFFIXES`) atomically, then read it back.

    Returns
    -------
    Written
        The file and what it holds, e.g. ``"2310 points, 4498 triangles, 130 point arrays
        (134 vertex properties)"``.

    Raises
    ------
    OutputPathError
        For an unsupported extension (or a ``MultiBlock`` not to ``.vtm``), a folder, a
        missing or read-only folder.
    WriteError
        If writing failed (a full disk) or the file does not read back; the old file is
        intact and no temporary file is left.
    """
    real = check_target(path, MESH_SUFFIXES)
    require_finite(path, mesh)
    suffix = real.suffix.lower()
    if isinstance(mesh, pv.MultiBlock) != (suffix == ".vtm"):
        kinds = (".vtm" if isinstance(mesh, pv.MultiBlock)
                 else ".vtp, .vtu, .vtk, .ply, .obj or .stl")
        raise OutputPathError(f"{str(path)!r}: a {type(mesh).__name__} is written as {kinds}; "
                              "change the extension")
    if suffix == ".vtm":
        return _save_multiblock(mesh, real)
    if suffix == ".ply":
        data, n_props = _ply_bytes(mesh)
        atomic_write_bytes(real, data, check=lambda tmp: _check_ply(tmp, mesh))
        what = f"{len(mesh.point_data)} point arrays ({n_props} vertex properties)"
    elif suffix in (".obj", ".stl"):
        data = _obj_bytes(mesh) if suffix == ".obj" else _stl_bytes(mesh)
        atomic_write_bytes(real, data, check=lambda tmp: _check_vtk(tmp, mesh, arrays=False))
        what = ("positions, vertex normals and triangles" if suffix == ".obj"
                else "triangles and facet normals")
    elif suffix == ".vtu":
        grid = _unstructured(mesh)
        atomic_write_bytes(real, _xml_bytes(grid), check=lambda tmp: _check_vtk(tmp, grid))
        what = f"{len(mesh.point_data)} point arrays"
    else:
        data = _xml_bytes(mesh) if suffix == ".vtp" else _legacy_bytes(mesh)
        atomic_write_bytes(real, data, check=lambda tmp: _check_vtk(tmp, mesh))
        what = f"{len(mesh.point_data)} point arrays"
    return Written(real, f"{mesh.n_points} points, {mesh.n_cells} triangles, {what}")


def _xml_writer(dataset):
    from vtkmodules import vtkIOXML

    kinds = {pv.PolyData: ("vtkXMLPolyDataWriter", ".vtp"),
             pv.UnstructuredGrid: ("vtkXMLUnstructuredGridWriter", ".vtu"),
             pv.ImageData: ("vtkXMLImageDataWriter", ".vti"),
             pv.StructuredGrid: ("vtkXMLStructuredGridWriter", ".vts"),
             pv.RectilinearGrid: ("vtkXMLRectilinearGridWriter", ".vtr")}
    for cls, (name, ext) in kinds.items():
        if isinstance(dataset, cls):
            return getattr(vtkIOXML, name)(), ext
    raise TypeError(f"cannot write a {type(dataset).__name__}; use PolyData")


def _xml_bytes(dataset) -> bytes:
    """VTK XML of ``dataset``, serialized in memory (base64 binary data, zlib)."""
    writer, _ = _xml_writer(dataset)
    writer.SetInputData(dataset)
    writer.SetDataModeToBinary()  # base64 inline; names may be any Unicode: UTF-8
    writer.SetWriteToOutputString(True)
    if not writer.Write():
        raise WriteError("VTK could not serialize the mesh")
    return writer.GetOutputString().encode("utf-8")


def _legacy_bytes(mesh: pv.PolyData) -> bytes:
    """Legacy binary VTK of ``mesh``, serialized in memory."""
    from vtkmodules.vtkIOLegacy import vtkPolyDataWriter

    writer = vtkPolyDataWriter()
    writer.SetInputData(mesh)
    writer.SetFileTypeToBinary()
    writer.SetWriteToOutputString(True)
    if not writer.Write():
        raise WriteError("VTK could not serialize the mesh")
    return bytes(writer.GetOutputStdString())


def _unstructured(mesh: pv.PolyData) -> pv.UnstructuredGrid:
    """``mesh`` as an unstructured grid, its string field arrays left out (meshio)."""
    grid = mesh.cast_to_unstructured_grid()
    for name in list(grid.field_data):
        if grid.GetFieldData().GetAbstractArray(name).IsA("vtkStringArray"):
            grid.field_data.remove(name)
    return grid


def _unit_of(mesh: pv.DataSet) -> str | None:
    """The unit recorded in ``mesh``'s field data ``unit`` (as ``to_polydata`` puts it)."""
    if "unit" not in mesh.field_data:
        return None
    return str(np.asarray(mesh.field_data["unit"]).ravel()[0])


def _triangles(mesh: pv.PolyData) -> tuple[pv.PolyData, np.ndarray]:
    if not mesh.is_all_triangles:
        mesh = mesh.triangulate()
    return mesh, np.asarray(mesh.faces).reshape(-1, 4)[:, 1:]


def _obj_bytes(mesh: pv.PolyData, comment: str = "") -> bytes:
    """Wavefront OBJ of ``mesh``: ``v``, ``vn`` (its active normals, else computed) and
    ``f v//vn`` lines, one-based; a comment line names the unit.
    """
    mesh, tris = _triangles(mesh)
    normals = mesh.GetPointData().GetNormals()
    if normals is None:
        normals = mesh.compute_normals(cell_normals=False, split_vertices=False,
                                       consistent_normals=False)["Normals"]
    else:
        normals = pv.convert_array(normals)
    unit = _unit_of(mesh)
    buffer = BytesIO()
    head = comment or "written by wrinkle-vis"
    buffer.write(f"# {head}{f'; lengths in {unit}' if unit else ''}\n".encode())
    np.savetxt(buffer, np.asarray(mesh.points, float), fmt="v %.10g %.10g %.10g")
    np.savetxt(buffer, np.asarray(normals, float), fmt="vn %.7g %.7g %.7g")
    np.savetxt(buffer, np.repeat(tris + 1, 2, axis=1), fmt="f %d//%d %d//%d %d//%d")
    return buffer.getvalue()


def _stl_bytes(mesh: pv.PolyData) -> bytes:
    """Binary STL of ``mesh``: an 80-byte header naming the unit, the triangle count and
    per triangle its unit normal, its three corners (float32) and a zero attribute.
    """
    mesh, tris = _triangles(mesh)
    corners = np.asarray(mesh.points, float)[tris]  # (m, 3, 3)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    record = np.zeros(len(tris), dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)),
                                        ("a", "<u2")])
    record["n"], record["v"] = normal, corners
    unit = _unit_of(mesh)
    header = f"wrinkle-vis{f'; lengths in {unit}' if unit else ''}".encode()[:80]
    return header.ljust(80, b" ") + len(tris).to_bytes(4, "little") + record.tobytes()


def _check_vtk(tmp: Path, mesh, arrays: bool = True) -> None:
    back = quiet_read(tmp)
    if back.n_points != mesh.n_points and not arrays:  # STL: three corners per triangle
        back = back.clean(tolerance=0.0)
    if back.n_points != mesh.n_points or back.n_cells != mesh.n_cells:
        raise ValueError(f"{back.n_points} points and {back.n_cells} cells instead of "
                         f"{mesh.n_points} and {mesh.n_cells}")
    if not arrays:
        return
    missing = set(mesh.point_data) - set(back.point_data)
    if missing:
        raise ValueError(f"arrays missing: {', '.join(sorted(missing))}")


def ply_properties(mesh: pv.PolyData) -> dict[str, np.ndarray]:
    """``{property name: (n,) array}``: the vertex properties :func:`save_mesh` writes to a
    PLY file for ``mesh``'s point arrays (a vector array ``a`` of 2 or 3 components as
    ``a_x, a_y[, a_z]``, more as ``a_0, a_1, ...``; names made ASCII by :func:`ply_name`).
    """
    out: dict[str, np.ndarray] = {}
    for name in mesh.point_data:
        values = np.asarray(mesh.point_data[name])
        base = ply_name(name)
        if values.ndim == 1:
            cols = {base: values}
        else:
            values = values.reshape(len(values), -1)
            k = values.shape[1]
            tags = "xyz" if k in (2, 3) else [str(i) for i in range(k)]
            cols = {f"{base}_{tags[i]}": values[:, i] for i in range(k)}
        for key, col in cols.items():
            if key in out or key in ("x", "y", "z"):
                raise OutputPathError(f"point array {name!r} gives the PLY property {key!r} "
                                      "twice; rename the array or write .vtp")
            out[key] = col
    return out


def ply_name(name: str) -> str:
    """A PLY property name for point array ``name``: whitespace as ``_``, any other
    character outside printable ASCII as ``_uXXXX`` (PLY headers are ASCII), e.g.
    ``"corrügatör_L.W"`` as ``"corr_u00fcgat_u00f6r_L.W"``.
    """
    name = re.sub(r"\s", "_", name)
    return "".join(c if " " < c < "\x7f" else f"_u{ord(c):04x}" for c in name) or "_"


def _ply_bytes(mesh: pv.PolyData) -> tuple[bytes, int]:
    """Binary little-endian PLY with every point array; returns it and the number of
    vertex properties beyond ``x y z``.
    """
    if not mesh.is_all_triangles:
        mesh = mesh.triangulate()
    props = ply_properties(mesh)
    tris = np.asarray(mesh.faces).reshape(-1, 4)[:, 1:]
    vdtype = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")] + [(k, "<f8") for k in props]
    vertices = np.empty(mesh.n_points, dtype=vdtype)
    vertices["x"], vertices["y"], vertices["z"] = np.asarray(mesh.points, float).T
    for key, col in props.items():
        vertices[key] = col
    faces = np.empty(len(tris), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"], faces["i"] = 3, tris
    header = ["ply", "format binary_little_endian 1.0", "comment written by wrinkle-vis",
              f"element vertex {mesh.n_points}"]
    header += [f"property double {k}" for k, _ in vdtype]
    header += [f"element face {len(tris)}", "property list uchar int vertex_indices",
               "end_header"]
    return ("\n".join(header) + "\n").encode("ascii") + vertices.tobytes() + \
        faces.tobytes(), len(props)


def _check_ply(tmp: Path, mesh: pv.PolyData) -> None:
    import meshio

    back = meshio.read(tmp, file_format="ply")
    n_tri = sum(len(c.data) for c in back.cells if c.type == "triangle")
    if len(back.points) != mesh.n_points or n_tri != mesh.n_cells:
        raise ValueError(f"{len(back.points)} points and {n_tri} triangles instead of "
                         f"{mesh.n_points} and {mesh.n_cells}")
    missing = set(ply_properties(mesh)) - set(back.point_data)
    if missing:
        raise ValueError(f"properties missing: {', '.join(sorted(missing))}")


# ---------------------------------------------------------------------- multiblocks
_PIECE = re.compile(r".+_\d+\.vt[a-z]$")
_VERSION_DIR = re.compile(r"v\d+-[0-9a-f]{6}-[0-9a-f]{8}")


def _is_piece(path: Path) -> bool:
    """A piece file, or a version folder holding only pieces."""
    if path.is_symlink():
        return False
    if path.is_dir() and _VERSION_DIR.fullmatch(path.name):
        return all(p.is_file() and not p.is_symlink() and _PIECE.match(p.name)
                   for p in path.iterdir())
    return path.is_file() and bool(_PIECE.match(path.name))


def _check_piece_folder(real: Path) -> None:
    folder = real.with_suffix("")
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        raise OutputPathError(f"{str(folder)!r} is in the way of the .vtm's pieces (they go "
                              "in a folder of that name); move it or choose another name")
    if folder.is_dir():
        tidy_versions(folder, real)  # versions that killed writers left
        others = [p.name for p in folder.iterdir() if not _is_piece(p)]
        if others:
            raise OutputPathError(
                f"folder {str(folder)!r}, where the .vtm's pieces go, holds other files "
                f"({', '.join(sorted(others)[:3])}); choose another name")


def _vtm_index(blocks: pv.MultiBlock, stem: str, version: str
               ) -> tuple[str, list[tuple[str, bytes]], list[tuple[str, int]]]:
    pieces: list[tuple[str, bytes]] = []
    counts: list[tuple[str, int]] = []
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="vtkMultiBlockDataSet" version="1.0" byte_order="LittleEndian" '
             'header_type="UInt32" compressor="vtkZLibDataCompressor">',
             "  <vtkMultiBlockDataSet>"]

    def walk(block: pv.MultiBlock, indent: str, where: str) -> None:
        for i in range(len(block)):
            name, child = block.get_block_name(i) or f"block{i}", block[i]
            label = f"{where}{name}"
            if isinstance(child, pv.MultiBlock):
                lines.append(f"{indent}<Block index=\"{i}\" name={quoteattr(name)}>")
                walk(child, indent + "  ", label + "/")
                lines.append(f"{indent}</Block>")
            elif child is None:
                lines.append(f"{indent}<DataSet index=\"{i}\" name={quoteattr(name)}/>")
            else:
                _, ext = _xml_writer(child)
                rel = f"{stem}/{version}/{stem}_{len(pieces)}{ext}"
                pieces.append((rel, _xml_bytes(child)))
                counts.append((label, child.n_points))
                lines.append(f"{indent}<DataSet index=\"{i}\" name={quoteattr(name)} "
                             f"file={quoteattr(rel)}/>")

    walk(blocks, "    ", "")
    lines += ["  </vtkMultiBlockDataSet>", "</VTKFile>", ""]
    return "\n".join(lines), pieces, counts


def _flatten(blocks, where: str = "") -> list[tuple[str, int]]:
    out = []
    for i in range(len(blocks)):
        name, child = blocks.get_block_name(i) or f"block{i}", blocks[i]
        if isinstance(child, pv.MultiBlock):
            out += _flatten(child, f"{where}{name}/")
        elif child is not None:
            out.append((f"{where}{name}", child.n_points))
    return out


def _save_multiblock(blocks: pv.MultiBlock, real: Path) -> Written:
    stem = real.stem
    folder = real.with_suffix("")
    version = new_version()
    index, pieces, counts = _vtm_index(blocks, stem, version)
    try:
        work = temp_folder(real.parent, stem)
    except OSError as exc:
        raise write_error(real, exc) from exc
    try:
        try:
            (work / stem / version).mkdir(parents=True)
            for rel, data in pieces:
                _write_synced(work / rel, data)
            _write_synced(work / real.name, index.encode("utf-8"))
            back = quiet_read(work / real.name)
        except OSError as exc:
            raise write_error(real, exc) from exc
        if _flatten(back) != counts:
            raise WriteError(f"could not write {str(real)!r}: the written file does not read "
                             "back; nothing was changed there")
        try:
            replace_indexed(work / stem / version, folder, work / real.name, real)
        except OSError as exc:
            raise write_error(real, exc) from exc
    finally:
        shutil.rmtree(work, ignore_errors=True)
    names = [blocks.get_block_name(i) for i in range(len(blocks))]
    return Written(real, f"{', '.join(names)} ({len(pieces)} pieces in "
                         f"{folder.name}/{version}/)")


def _write_synced(path: Path, data: bytes) -> None:
    with open(path, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


# ---------------------------------------------------------------------- images
def save_image(image: np.ndarray, path: str | os.PathLike) -> Written:
    """Write an ``(h, w, 3|4) uint8`` image as PNG atomically (see :func:`save_mesh`)."""
    from PIL import Image

    real = check_target(path, IMAGE_SUFFIXES)
    image = np.ascontiguousarray(image)
    buffer = BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")

    def check(tmp: Path) -> None:  # the PNG signature and the IHDR chunk's size
        with open(tmp, "rb") as fh:
            head = fh.read(24)
        if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
            raise ValueError("not a PNG file")
        w, h = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
        if (w, h) != (image.shape[1], image.shape[0]):
            raise ValueError(f"the PNG is {w} by {h} pixels")

    atomic_write_bytes(real, buffer.getvalue(), check=check)
    return Written(real, f"{image.shape[1]} by {image.shape[0]} pixels")


# ---------------------------------------------------------------------- animations
def save_animation(frames: Iterable[np.ndarray], path: str | os.PathLike,
                   fps: float) -> Written:
    """Stream ``frames`` (``(h, w, 3) uint8`` each, all one size) to a GIF or MP4 atomically.

    Frames are written as they come (none is kept), so memory stays flat however many there
    are. GIF: every frame with its own 256-colour palette, looping; MP4: H.264 (ffmpeg).

    Raises
    ------
    OutputPathError, WriteError
        As :func:`save_mesh`; the old file is intact after a failure.
    """
    real = check_target(path, ANIMATION_SUFFIXES)
    if not fps > 0:
        raise ValueError(f"fps = {fps} must be positive")
    count = 0
    with atomic_output(real) as tmp:
        if real.suffix.lower() == ".gif":
            with open(tmp, "wb") as fh:
                gif = _GifStream(fh, fps)
                for frame in frames:
                    gif.add(frame)
                    count += 1
                gif.close()
        else:
            count = _write_mp4(frames, tmp, fps)
        if count == 0:
            raise ValueError("no frames to write")
    return Written(real, f"{count} frames")


def _write_mp4(frames: Iterable[np.ndarray], tmp: Path, fps: float) -> int:
    """Pipe raw frames into ffmpeg (H.264, yuv420p; odd sizes padded by a pixel); its exit
    status and last error line are checked, so a full disk is an error, not a short file.
    """
    import errno
    import subprocess

    import imageio_ffmpeg

    count, proc, log = 0, None, tempfile.TemporaryFile()
    try:
        for frame in frames:
            frame = np.ascontiguousarray(np.asarray(frame)[..., :3], dtype=np.uint8)
            if proc is None:
                h, w = frame.shape[:2]
                size = (w, h)
                proc = subprocess.Popen(
                    [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-v", "error", "-f", "rawvideo",
                     "-vcodec", "rawvideo", "-s", f"{w}x{h}", "-pix_fmt", "rgb24",
                     "-r", f"{fps:g}", "-i", "-", "-an", "-vcodec", "libx264",
                     "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                     "-f", "mp4", str(tmp)],
                    stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log,
                    preexec_fn=_die_with_parent())
            elif frame.shape[1::-1] != size:
                raise ValueError(f"frame {count} is {frame.shape[1::-1]}, the first {size}")
            try:
                proc.stdin.write(frame.tobytes())
            except BrokenPipeError:
                break  # ffmpeg stopped: its exit status and log say why
            count += 1
        if proc is not None:
            try:
                proc.stdin.close()
            except BrokenPipeError:
                pass
            if proc.wait() != 0:
                log.seek(0)
                lines = [x for x in log.read().decode("utf-8", "replace").splitlines() if x]
                last = lines[-1].strip() if lines else f"exit status {proc.returncode}"
                if "No space left" in last or any("No space left" in x for x in lines):
                    raise OSError(errno.ENOSPC, "No space left on device")
                raise OSError(f"ffmpeg failed: {last}")
    finally:
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()
        log.close()
    return count


def _die_with_parent():
    """A ``preexec_fn`` that has the child killed when this process dies (Linux
    ``PR_SET_PDEATHSIG``), so a killed ``animate`` leaves no ffmpeg running; None elsewhere.
    """
    import ctypes
    import signal
    import sys

    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl  # looked up before the fork
    except (OSError, AttributeError):
        return None

    def set_death_signal() -> None:
        prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG

    return set_death_signal


class _GifStream:
    """An animated GIF written frame by frame: Pillow encodes each frame (its own palette)
    as a one-frame GIF, whose image block is copied into the stream.
    """

    def __init__(self, fh, fps: float):
        self.fh, self.fps, self.count, self.size = fh, float(fps), 0, None

    def add(self, frame: np.ndarray) -> None:
        from PIL import Image

        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.shape[2] not in (3, 4) or frame.dtype != np.uint8:
            raise ValueError(f"a frame must be (h, w, 3) uint8; got {frame.shape} "
                             f"{frame.dtype}")
        im = Image.fromarray(np.ascontiguousarray(frame[..., :3]))
        if self.size is None:
            self.size = im.size
            w, h = im.size
            # header, screen (no global colour table), loop forever (NETSCAPE2.0)
            self.fh.write(b"GIF89a" + _u16(w) + _u16(h) + b"\x00\x00\x00")
            self.fh.write(b"\x21\xff\x0bNETSCAPE2.0\x03\x01\x00\x00\x00")
        elif im.size != self.size:
            raise ValueError(f"frame {self.count} is {im.size}, the first {self.size}")
        quantized = im.quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                                dither=Image.Dither.NONE)
        one = BytesIO()
        # not interlaced: the descriptor written below says so (Pillow interlaces by default)
        quantized.save(one, format="GIF", interlace=False)
        table, size_bits, interlaced, block = _gif_image_block(one.getvalue())
        delay = round(100 * (self.count + 1) / self.fps) - round(100 * self.count / self.fps)
        # graphic control: no disposal, the delay in 1/100 s
        self.fh.write(b"\x21\xf9\x04\x04" + _u16(delay) + b"\x00\x00")
        w, h = self.size
        self.fh.write(b"\x2c" + _u16(0) + _u16(0) + _u16(w) + _u16(h)
                      + bytes([0x80 | interlaced | size_bits]) + table + block)
        self.fh.flush()  # on disk now: nothing of the frame stays in memory
        self.count += 1

    def close(self) -> None:
        if self.count:
            self.fh.write(b"\x3b")


def _u16(value: int) -> bytes:
    return int(value).to_bytes(2, "little")


def _gif_image_block(data: bytes) -> tuple[bytes, int, int, bytes]:
    """From a one-frame GIF: its colour table, the table's size bits, its interlace flag
    (``0x40`` or 0, to be copied into the descriptor that precedes the LZW data, whose row
    order it states) and the LZW data (the minimum code size and the sub-blocks, terminator
    included).
    """
    pos = 13
    packed = data[10]
    table, bits = b"", 0
    if packed & 0x80:
        bits = packed & 7
        table = data[pos:pos + 3 * 2 ** (bits + 1)]
        pos += len(table)
    while pos < len(data):
        kind = data[pos]
        if kind == 0x21:  # an extension: skip its sub-blocks
            pos += 2
            while data[pos]:
                pos += data[pos] + 1
            pos += 1
        elif kind == 0x2C:
            local = data[pos + 9]
            interlaced = local & 0x40
            pos += 10
            if local & 0x80:
                bits = local & 7
                table = data[pos:pos + 3 * 2 ** (bits + 1)]
                pos += len(table)
            start = pos
            pos += 1  # LZW minimum code size
            while data[pos]:
                pos += data[pos] + 1
            return table, bits, interlaced, data[start:pos + 1]
        else:
            break
    raise ValueError("Pillow wrote a GIF without an image")
