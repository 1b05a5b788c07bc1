"""Exchange formats: an expression's ramp as a time series, and the expressions as glTF
morph targets (no Qt).

Formats
-------
``NAME.pvd``
    A ParaView time series: the collection file indexes one ``.vtp`` per frame in a version
    folder inside the folder ``NAME/`` beside it (``NAME/v<pid>-<host>-<hex>/NAME_0000.vtp``, ...),
    each with every field as a point array (:func:`~wrinkle_vis.plotting.to_polydata`) and
    its time as the field array ``TimeValue``. The new version goes in, the collection file
    is renamed over the old one, then the old version goes: a kill at any point leaves a
    collection over its own frames (:func:`~wrinkle_vis.core.files.replace_indexed`).
``NAME_####.obj``, ``NAME_####.ply``
    One numbered file per frame, in the folder ``NAME/`` beside the pattern
    (:func:`sequence_folder`), which is replaced whole in one step
    (:func:`~wrinkle_vis.core.files.replace_folder`), so a kill never leaves frames of two
    runs mixed (the run of ``#`` is the frame number, zero-padded; a name without ``#``
    gets ``_####``). OBJ holds the positions, vertex normals and triangles;
    PLY every field as vertex properties (as :func:`~wrinkle_vis.plotting.writers.save_mesh`
    writes it).
``NAME.glb``
    Binary glTF 2.0: the neutral skin as the mesh (positions, normals, triangles) and one
    morph target per expression, the expression's wrinkled surface at full intensity as
    ``POSITION`` (and ``NORMAL``) displacements from the neutral skin; a skin with UVs
    (a scan) has them as ``TEXCOORD_0``, so baked maps fit it. The target names are
    in ``mesh.extras.targetNames`` (Blender and three.js read them). glTF lengths are
    metres: the face's lengths are scaled by its unit (the built-in face is in
    millimetres, so by 0.001); +y is up and the face looks along +z, as in glTF.

Every writer checks its target before any work, writes beside it, reads the result back
and renames it into place (:mod:`wrinkle_vis.core.files`): a failure leaves the old files
as they were.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pyvista as pv

from ..core.face import FaceModel, FaceState
from ..core.files import (
    OutputPathError,
    WriteError,
    atomic_write_bytes,
    check_output,
    new_version,
    replace_indexed,
    temp_folder,
    write_error,
)
from ..core.units import LENGTH_UNITS, face_unit
from ..datasets.meshfile import quiet_read
from .finite import require_finite
from .polydata import to_polydata
from .writers import (
    Written,
    _ply_bytes,
    _write_synced,
    _xml_bytes,
    check_target,
    replace_folder,
)

__all__ = ["GLTF_SUFFIXES", "METRES_PER_UNIT", "SEQUENCE_SUFFIXES", "check_sequence_target",
           "face_unit", "gltf_bytes", "numbered_path", "read_glb", "save_gltf",
           "save_sequence", "sequence_folder", "sequence_states"]

#: Formats :func:`save_sequence` writes.
SEQUENCE_SUFFIXES = (".pvd", ".obj", ".ply")
#: Formats :func:`save_gltf` writes.
GLTF_SUFFIXES = (".glb",)
#: Metres in one unit of a face's lengths, by the unit's name.
METRES_PER_UNIT = LENGTH_UNITS


# ---------------------------------------------------------------------- sequences
def sequence_states(face: FaceModel, expression, times: Sequence[float],
                    intensity: float = 1.0) -> Iterable[FaceState]:
    """The states of ``expression`` (an :class:`~wrinkle_vis.core.expressions.Expression`)
    at each of ``times`` (seconds), evaluated one at a time as they are asked for (simulated
    on a face whose skin model is the physical one: :meth:`FaceModel.expression_states`).
    """
    yield from face.expression_states(expression, times, intensity)


def _numbered_parts(path: Path, count: int) -> tuple[str, int, str]:
    """The file name before the frame number, the number's width, and the rest."""
    stem, suffix = path.stem, path.suffix
    runs = list(re.finditer(r"#+", stem))
    if not runs:
        stem += "_####"
        runs = list(re.finditer(r"#+", stem))
    run = runs[-1]
    width = max(len(run.group()), len(str(max(count - 1, 0))))
    return stem[:run.start()], width, stem[run.end():] + suffix


def sequence_folder(path: str | os.PathLike) -> Path:
    """The folder the frames of a pattern such as ``NAME_####.obj`` go in: ``NAME/`` beside
    it (the name before the frame number, without a trailing ``_``, ``-`` or ``.``;
    ``frames`` if that leaves nothing).
    """
    path = Path(path)
    head, _, tail = _numbered_parts(path, 1)
    rest = tail[:len(tail) - len(path.suffix)]
    name = head.rstrip("_-. ") or rest.strip("_-. ") or "frames"
    return path.with_name(name)


def numbered_path(path: str | os.PathLike, index: int, count: int) -> Path:
    """The file of frame ``index`` of ``count`` for a pattern such as ``NAME_####.obj``.

    The last run of ``#`` in the file name becomes the frame number, zero-padded to the
    run's length (or more digits when ``count`` needs them); a name without ``#`` gets
    ``_`` and four digits before its extension. The file lies in :func:`sequence_folder`.
    """
    path = Path(path)
    head, width, tail = _numbered_parts(path, count)
    return sequence_folder(path) / f"{head}{index:0{width}d}{tail}"


def check_sequence_target(path: str | os.PathLike) -> Path:
    """Check a sequence's target before any work (:data:`SEQUENCE_SUFFIXES`; for ``.pvd``
    also its frames' folder, see :func:`~wrinkle_vis.plotting.writers.check_target`; for
    numbered files that their folder holds nothing else).
    """
    real = check_target(path, SEQUENCE_SUFFIXES)
    if real.suffix.lower() != ".pvd":
        _check_frame_folder(real)
    return real


def _check_frame_folder(real: Path) -> None:
    folder = sequence_folder(real)
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        raise OutputPathError(f"{str(folder)!r} is in the way of the frames (they go in a "
                              "folder of that name); move it or choose another name")
    if folder.is_dir():
        head, _, tail = _numbered_parts(real, 1)
        frame = re.compile(f"{re.escape(head)}[0-9]+{re.escape(tail)}")
        others = [p.name for p in folder.iterdir()
                  if p.is_symlink() or not (p.is_file() and frame.fullmatch(p.name))]
        if others:
            raise OutputPathError(
                f"folder {str(folder)!r}, where the frames go, holds other files "
                f"({', '.join(sorted(others)[:3])}); the frames replace it whole: choose "
                "another name")


def save_sequence(states: Iterable[FaceState], times: Sequence[float],
                  path: str | os.PathLike) -> Written:
    """Write the frames ``states`` (one per time of ``times``, seconds) as a time series.

    ``.pvd``: a ParaView collection and a folder of ``.vtp`` frames beside it; ``.obj``,
    ``.ply``: one numbered file per frame (:func:`numbered_path`) in a folder of their own
    (:func:`sequence_folder`). Frames are written as they come (none is kept in memory), to
    a hidden folder beside the target, read back, and only then put in place, the old
    sequence replaced as a whole (a kill at any point leaves the old one or the new one),
    so a tool that reads the numbered files finds this sequence only.

    Parameters
    ----------
    states : iterable of FaceState
        The frames, e.g. :func:`sequence_states` (wrap it in a progress bar if you like).
    times : (k,) float
        Their times in seconds.
    path : path
        ``NAME.pvd``, ``NAME_####.obj`` or ``NAME_####.ply``.

    Returns
    -------
    Written
        The ``.pvd`` file or the first frame's file, and what was written.

    Raises
    ------
    OutputPathError
        For an unsupported extension, a folder, a missing or read-only folder, or a frame
        folder that holds other files.
    WriteError
        If writing failed (a full disk) or the frames do not read back; nothing was changed.
    """
    real = check_sequence_target(path)
    times = [float(t) for t in times]
    if not times:
        raise ValueError("no frames to write")
    suffix = real.suffix.lower()
    try:
        work = temp_folder(real.parent, real.stem)
    except OSError as exc:
        raise write_error(real, exc) from exc
    try:
        if suffix == ".pvd":
            return _save_pvd(states, times, real, work)
        return _save_numbered(states, times, real, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _frames(states: Iterable[FaceState], times: list[float]):
    n = 0
    for n, (t, state) in enumerate(zip(times, states, strict=False), start=1):
        yield n - 1, t, state
    if n != len(times):
        raise ValueError(f"{n} frames for {len(times)} times")


def _save_pvd(states, times: list[float], real: Path, work: Path) -> Written:
    stem, folder, version = real.stem, real.with_suffix(""), new_version()
    width = max(4, len(str(len(times) - 1)))
    rel = [f"{stem}/{version}/{stem}_{i:0{width}d}.vtp" for i in range(len(times))]
    first = None
    try:
        (work / stem / version).mkdir(parents=True)
        for i, t, state in _frames(states, times):
            require_finite(real, state)
            mesh = to_polydata(state)
            mesh.field_data["TimeValue"] = np.array([t])
            if first is None:
                first = (mesh.n_points, mesh.n_cells, sorted(mesh.point_data))
            _write_synced(work / rel[i], _xml_bytes(mesh))
        lines = ['<?xml version="1.0"?>',
                 '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
                 "  <Collection>"]
        lines += [f'    <DataSet timestep="{t!r}" group="" part="0" file={quoteattr(r)}/>'
                  for t, r in zip(times, rel, strict=True)]
        lines += ["  </Collection>", "</VTKFile>", ""]
        _write_synced(work / real.name, "\n".join(lines).encode("utf-8"))
    except OSError as exc:
        raise write_error(real, exc) from exc
    try:
        _check_pvd(work / real.name, times, first)
    except Exception as exc:  # any failure to read back rejects the series
        why = " ".join(str(exc).split()) or type(exc).__name__
        raise WriteError(f"could not write {str(real)!r}: the written series does not read "
                         f"back ({why}); nothing was changed there") from exc
    try:
        replace_indexed(work / stem / version, folder, work / real.name, real)
    except OSError as exc:
        raise write_error(real, exc) from exc
    return Written(real, f"{len(times)} frames from t = {times[0]:g} to {times[-1]:g} s in "
                         f"{folder.name}/{version}/, {first[0]} points, {first[1]} triangles, "
                         f"{len(first[2])} point arrays each")


def _check_pvd(index: Path, times: list[float], first) -> None:
    reader = pv.get_reader(str(index))
    if not np.allclose(reader.time_values, times, rtol=0, atol=1e-12):
        raise ValueError(f"{len(reader.time_values)} time steps instead of {len(times)}")
    for k in {0, len(times) - 1}:
        reader.set_active_time_point(k)
        mesh = reader.read()
        if isinstance(mesh, pv.MultiBlock):
            mesh = mesh[0]
        if (mesh.n_points, mesh.n_cells, sorted(mesh.point_data)) != tuple(first):
            raise ValueError(f"frame {k} has {mesh.n_points} points, {mesh.n_cells} cells "
                             f"and {len(mesh.point_data)} point arrays")


def _obj_bytes(state: FaceState, t: float) -> bytes:
    """OBJ of the final skin of ``state``: positions, unit vertex normals, triangles."""
    from io import BytesIO

    buffer = BytesIO()
    face = state.face
    buffer.write(f"# wrinkle-vis: {face.name}, t = {t!r} s, lengths in "
                 f"{face_unit(face)}\n".encode())
    np.savetxt(buffer, np.asarray(state.points), fmt="v %.10g %.10g %.10g")
    np.savetxt(buffer, np.asarray(state.normals), fmt="vn %.7g %.7g %.7g")
    tris = face.skin.triangles + 1
    np.savetxt(buffer, np.repeat(tris, 2, axis=1), fmt="f %d//%d %d//%d %d//%d")
    return buffer.getvalue()


def _save_numbered(states, times: list[float], real: Path, work: Path) -> Written:
    n = len(times)
    targets = [numbered_path(real, i, n) for i in range(n)]
    folder = targets[0].parent
    new = work / folder.name
    ply = real.suffix.lower() == ".ply"
    first = None
    try:
        new.mkdir()
        for i, t, state in _frames(states, times):
            require_finite(real, state)
            if ply:
                mesh = to_polydata(state)
                data, _ = _ply_bytes(mesh)
                first = first or (mesh.n_points, mesh.n_cells, len(mesh.point_data))
            else:
                data = _obj_bytes(state, t)
                first = first or (state.n_points, state.face.skin.n_triangles, 0)
            _write_synced(new / targets[i].name, data)
    except OSError as exc:
        raise write_error(real, exc) from exc
    for k in {0, n - 1}:  # read back the first and the last frame
        try:
            back = quiet_read(new / targets[k].name)
            if (back.n_points, back.n_cells) != first[:2]:
                raise ValueError(f"{back.n_points} points and {back.n_cells} cells instead "
                                 f"of {first[0]} and {first[1]}")
        except Exception as exc:
            why = " ".join(str(exc).split()) or type(exc).__name__
            raise WriteError(f"could not write {str(targets[k])!r}: the written file does "
                             f"not read back ({why}); nothing was changed there") from exc
    try:
        replace_folder(new, folder)
    except OSError as exc:
        raise write_error(real, exc) from exc
    what = (f"{first[2]} point arrays as vertex properties" if ply
            else "positions, normals and triangles")
    return Written(targets[0], f"{n} frames in {folder.name}/, {targets[0].name} to "
                               f"{targets[-1].name}, "
                               f"{first[0]} points, {first[1]} triangles, {what} each")


# ---------------------------------------------------------------------- glTF
_FLOAT, _UINT16, _UINT32 = 5126, 5123, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


def _split_at_seams(triangles: np.ndarray,
                    corner_uvs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One glTF vertex per distinct (skin vertex, UV) pair: a vertex on a UV seam becomes
    one per side.

    Returns
    -------
    vertex : (k,) int
        The skin vertex of each glTF vertex.
    uv : (k, 2) float
        Its UV (OBJ's convention, ``v`` up).
    triangles : (m, 3) int
        The triangles on the glTF vertices.
    """
    corners = np.asarray(triangles).reshape(-1)
    key = np.column_stack([corners.astype(float), np.asarray(corner_uvs, float).reshape(-1, 2)])
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return corners[first], key[first, 1:], inverse.reshape(-1, 3)


def gltf_bytes(face: FaceModel, expressions: Sequence[str] | None = None, *,
               unit: str | None = None,
               progress: Callable[[Iterable], Iterable] | None = None,
               corner_uvs: np.ndarray | None = None) -> tuple[bytes, dict]:
    r"""Binary glTF 2.0 of ``face``: the neutral skin with one morph target per expression.

    Parameters
    ----------
    face : FaceModel
        The face.
    expressions : sequence of str, optional
        The expressions to make targets of, in order (default: all of ``face``'s).
    unit : str, optional
        The unit of ``face``'s lengths, a key of :data:`METRES_PER_UNIT` (default:
        :func:`face_unit`); glTF lengths are metres.
    progress : callable, optional
        Wraps the iterable of expression names (e.g. ``tqdm``), to show progress.
    corner_uvs : (m, 3, 2) float, optional
        The UVs of every corner of the skin's triangles
        (:func:`~wrinkle_vis.plotting.bake.read_obj_uvs`): written as ``TEXCOORD_0``, so
        the maps of :func:`~wrinkle_vis.plotting.bake.bake_maps` fit the mesh. glTF's
        ``v`` points down (``(u, 1 - v)`` of OBJ's), and a vertex on a UV seam becomes
        one glTF vertex per side (its position, normal and morph targets repeated).

    Returns
    -------
    data : bytes
        The GLB file: a 12-byte header, a JSON chunk (padded with spaces) and a BIN chunk
        (padded with zeros), every chunk and buffer view 4-byte aligned.
    gltf : dict
        Its JSON part.

    Notes
    -----
    Target ``k`` holds ``POSITION`` :math:`= s\,(x_k - x_0)` and ``NORMAL``
    :math:`= n_k - n_0`, float32, where :math:`x_0, n_0` are the neutral skin's points and
    unit vertex normals, :math:`x_k, n_k` those of ``face.evaluate(expression)`` (the
    wrinkled surface at full intensity) and :math:`s` the metres per unit. Every
    ``POSITION`` accessor has its ``min`` and ``max``, as glTF requires.
    """
    names = list(face.expressions if expressions is None else expressions)
    unit = unit or face_unit(face)
    if unit not in METRES_PER_UNIT:
        raise ValueError(f"unknown unit {unit!r}; choose from {', '.join(METRES_PER_UNIT)}")
    scale = METRES_PER_UNIT[unit]
    base = face.evaluate({})
    vertex, uv, tris = _glb_vertices(face, corner_uvs)
    x0 = np.asarray(base.points, float)[vertex]
    n0 = np.asarray(base.normals, float)[vertex]
    buf = _GlbBuffer()
    p0 = (x0 * scale).astype(np.float32)
    primitive = _neutral_primitive(buf, p0, n0, uv, tris)
    targets = [_morph_target(buf, face.evaluate(name), vertex, p0, n0, scale)
               for name in (progress or (lambda x: x))(names)]
    blob = b"".join(buf.chunks)
    gltf = _gltf_json(face.name, _morphing_mesh(face.name, primitive, targets, names), unit,
                      scale, buf, len(blob))
    return _glb(gltf, blob), gltf


def _morphing_mesh(name: str, primitive: dict, targets: list[dict], names: list[str]) -> dict:
    """The glTF mesh of ``primitive`` with morph ``targets`` named ``names`` (if any)."""
    mesh = {"name": name, "primitives": [primitive]}
    if targets:
        primitive["targets"] = targets
        mesh["weights"] = [0.0] * len(targets)
        mesh["extras"] = {"targetNames": names}
    return mesh


def _glb(gltf: dict, blob: bytes) -> bytes:
    """The GLB file of JSON part ``gltf`` and BIN chunk ``blob``."""
    text = json.dumps(gltf, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(blob)
    return b"".join([b"glTF", _u32(2), _u32(total), _u32(len(text)), b"JSON", text,
                     _u32(len(blob)), b"BIN\0", blob])


def _neutral_primitive(buf: _GlbBuffer, p0: np.ndarray, n0: np.ndarray,
                       uv: np.ndarray | None, tris: np.ndarray) -> dict:
    """The mesh primitive of the neutral skin: points ``p0`` and normals ``n0`` ``(v, 3)``,
    UVs ``(v, 2)`` when given (glTF's v down) and triangles ``tris`` ``(m, 3)``.
    """
    attributes = {"POSITION": buf.add(p0, "VEC3", _FLOAT, _ARRAY_BUFFER, True),
                  "NORMAL": buf.add(n0.astype(np.float32), "VEC3", _FLOAT, _ARRAY_BUFFER,
                                    False)}
    if uv is not None:
        texcoord = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype(np.float32)
        attributes["TEXCOORD_0"] = buf.add(texcoord, "VEC2", _FLOAT, _ARRAY_BUFFER, False)
    small = len(p0) < 65535
    indices = buf.add(tris.astype(np.uint16 if small else np.uint32).reshape(-1, 1), "SCALAR",
                      _UINT16 if small else _UINT32, _ELEMENT_ARRAY_BUFFER, False)
    buf.accessors[indices]["count"] = int(tris.size)
    return {"attributes": attributes, "indices": indices, "mode": 4, "material": 0}


def _glb_vertices(face: FaceModel, corner_uvs: np.ndarray | None
                  ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """The glTF vertices: the skin vertex of each ``(v,)``, its UV ``(v, 2)`` (None
    without ``corner_uvs``) and the triangles on them ``(m, 3)``; a vertex on a UV seam
    becomes one per side.
    """
    tris = np.asarray(face.skin.triangles)
    if corner_uvs is None:
        return np.arange(face.skin.n_points), None, tris
    corner_uvs = np.asarray(corner_uvs, float)
    if corner_uvs.shape != (len(tris), 3, 2):
        raise ValueError(f"corner_uvs is {corner_uvs.shape}; expected ({len(tris)}, 3, 2)")
    vertex, uv, tris = _split_at_seams(tris, corner_uvs)
    return vertex, uv, tris


class _GlbBuffer:
    """The BIN chunk of a GLB as it is written: its chunks, buffer views and accessors."""

    def __init__(self):
        self.chunks: list[bytes] = []
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, array: np.ndarray, kind: str, component: int, target: int,
            bounds: bool) -> int:
        """Append ``array`` (4-byte aligned) with its view and accessor (``bounds``: with
        its ``min`` and ``max``); returns the accessor's index.
        """
        require_finite("the glTF file", {f"a {kind} accessor": array})
        raw = np.ascontiguousarray(array).tobytes()
        offset = sum(len(c) for c in self.chunks)
        self.chunks.append(raw + b"\0" * (-len(raw) % 4))
        self.views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(raw),
                           "target": target})
        acc = {"bufferView": len(self.views) - 1, "componentType": component,
               "count": int(array.shape[0]), "type": kind}
        if bounds:
            acc["min"] = [float(v) for v in array.min(axis=0)]
            acc["max"] = [float(v) for v in array.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _morph_target(buf: _GlbBuffer, state, vertex: np.ndarray, p0: np.ndarray, n0: np.ndarray,
                  scale: float) -> dict[str, int]:
    """The morph target of frame ``state`` on glTF vertices ``vertex`` (from the neutral
    ``p0``, float32 metres, and ``n0``): its POSITION and NORMAL accessors.
    """
    # float32 displacements from the float32 base: base + target is the float32 nearest
    # the wrinkled point
    moved = (np.asarray(state.points)[vertex] * scale).astype(np.float32)
    dp = (moved.astype(np.float64) - p0).astype(np.float32)
    dn = (np.asarray(state.normals)[vertex] - n0).astype(np.float32)
    return {"POSITION": buf.add(dp, "VEC3", _FLOAT, _ARRAY_BUFFER, True),
            "NORMAL": buf.add(dn, "VEC3", _FLOAT, _ARRAY_BUFFER, False)}


def _gltf_json(name: str, mesh: dict, unit: str, scale: float, buf: _GlbBuffer,
               n_bytes: int) -> dict:
    """The JSON part of the GLB: one node of ``mesh``, a skin material, the buffer."""
    return {
        "asset": {"version": "2.0", "generator": f"wrinkle-vis {_version()}"},
        "extras": {"unit": "m", "source_unit": unit, "metres_per_source_unit": scale},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": name, "mesh": 0}],
        "meshes": [mesh],
        "materials": [{"name": "skin", "pbrMetallicRoughness": {
            "baseColorFactor": [0.87, 0.72, 0.62, 1.0], "metallicFactor": 0.0,
            "roughnessFactor": 0.6}}],
        "buffers": [{"byteLength": n_bytes}],
        "bufferViews": buf.views,
        "accessors": buf.accessors,
    }


def _u32(value: int) -> bytes:
    return int(value).to_bytes(4, "little")


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("wrinkle-vis")
    except PackageNotFoundError:
        return "dev"


def read_glb(path: str | os.PathLike) -> tuple[dict, bytes]:
    """The JSON part and the BIN chunk of a GLB file, its structure checked.

    Raises
    ------
    ValueError
        If the header, a chunk's type, length or alignment, or a buffer view or accessor
        does not fit.
    """
    data = Path(path).read_bytes()
    if data[:4] != b"glTF" or int.from_bytes(data[4:8], "little") != 2:
        raise ValueError("not a glTF 2.0 binary file")
    if int.from_bytes(data[8:12], "little") != len(data) or len(data) % 4:
        raise ValueError("the header's length is not the file's")
    n_json = int.from_bytes(data[12:16], "little")
    if data[16:20] != b"JSON" or n_json % 4:
        raise ValueError("the first chunk is not a 4-byte aligned JSON chunk")
    gltf = json.loads(data[20:20 + n_json])
    pos = 20 + n_json
    n_bin = int.from_bytes(data[pos:pos + 4], "little")
    if data[pos + 4:pos + 8] != b"BIN\0" or n_bin % 4 or pos + 8 + n_bin != len(data):
        raise ValueError("the second chunk is not a 4-byte aligned BIN chunk ending the file")
    blob = data[pos + 8:]
    if not 0 <= n_bin - gltf["buffers"][0]["byteLength"] < 4:
        raise ValueError("the buffer's byteLength is not the BIN chunk's")
    sizes = {_FLOAT: 4, _UINT16: 2, _UINT32: 4}
    widths = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}
    for view in gltf["bufferViews"]:
        if view["byteOffset"] % 4 or view["byteOffset"] + view["byteLength"] > n_bin:
            raise ValueError(f"buffer view {view} is misaligned or outside the buffer")
    for acc in gltf["accessors"]:
        view = gltf["bufferViews"][acc["bufferView"]]
        need = acc["count"] * sizes[acc["componentType"]] * widths[acc["type"]]
        if acc.get("byteOffset", 0) + need > view["byteLength"]:
            raise ValueError(f"accessor {acc} overruns its buffer view")
    return gltf, blob


def _check_glb(tmp: Path, expected: dict) -> None:
    gltf, _ = read_glb(tmp)
    if gltf != expected:
        raise ValueError("the JSON part differs from what was written")


def save_gltf(face: FaceModel, path: str | os.PathLike,
              expressions: Sequence[str] | None = None, *, unit: str | None = None,
              progress: Callable[[Iterable], Iterable] | None = None,
              corner_uvs: np.ndarray | None = None) -> Written:
    """Write ``face`` as binary glTF with one morph target per expression
    (:func:`gltf_bytes`; with ``corner_uvs`` its UVs as ``TEXCOORD_0``), atomically; the
    file is read back and its structure checked.

    Raises
    ------
    OutputPathError
        For an extension other than ``.glb``, a folder, a missing or read-only folder.
    ValueError
        For an unknown expression or unit.
    WriteError
        If writing failed or the file does not read back; the old file is intact.
    """
    real = check_output(path, GLTF_SUFFIXES)
    names = list(face.expressions if expressions is None else expressions)
    unknown = [n for n in names if n not in face.expressions]
    if unknown:
        raise ValueError(f"unknown expression(s) {', '.join(map(repr, unknown))}; choose "
                         f"from: {', '.join(face.expressions)}")
    data, gltf = gltf_bytes(face, names, unit=unit, progress=progress, corner_uvs=corner_uvs)
    atomic_write_bytes(real, data, check=lambda tmp: _check_glb(tmp, gltf))
    scale = gltf["extras"]["metres_per_source_unit"]
    n_vertices = gltf["accessors"][gltf["meshes"][0]["primitives"][0]["attributes"][
        "POSITION"]]["count"]
    uvs = "" if corner_uvs is None else f" ({n_vertices} vertices with UVs)"
    return Written(real, f"{face.skin.n_points} points{uvs}, {face.skin.n_triangles} "
                         f"triangles, "
                         f"{len(names)} morph targets ({', '.join(names)}); lengths in "
                         f"metres ({gltf['extras']['source_unit']} times {scale:g})")

