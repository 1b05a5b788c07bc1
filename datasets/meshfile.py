"""Checking a mesh file before a reader sees it, and reading it quietly.

VTK's readers trust what a file says: a 193-byte PLY whose header claims 10^12 vertices, an
ASCII PLY claiming 2e9, or an OBJ face whose ``vt`` index is out of range kill the process
(SIGSEGV, or ``std::bad_alloc`` and abort), and unreadable files print pages of VTK errors.
:func:`check_mesh_file` checks, before any reader runs, what such a file claims against what
it holds: element counts against the file's size (PLY, binary STL, legacy VTK, VTK XML) and
OBJ's ``v``/``vt``/``vn`` indices against their counts (vectorized, chunk by chunk, so a
scan of a million triangles costs a fraction of a second), and refuses files that are not
meshes at all (empty, binary zeros in a text format). :func:`quiet_vtk` keeps VTK's and
PyVista's messages off the terminal while a file is read: the caller says what went wrong in
one line.
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from wrinkle_vis.core import MeshError

__all__ = ["check_mesh_file", "obj_index_ranges", "quiet_read", "quiet_vtk"]

#: The most bytes a PLY or legacy-VTK header may take before its data.
HEADER_LIMIT = 1 << 16

#: Bytes of a PLY property of each type.
PLY_TYPES = {name: size for names, size in (
    (("char", "int8", "uchar", "uint8"), 1), (("short", "int16", "ushort", "uint16"), 2),
    (("int", "int32", "uint", "uint32", "float", "float32"), 4),
    (("double", "float64"), 8)) for name in names}

#: The longest line an OBJ file may have.
LINE_LIMIT = 1 << 20

#: Bytes a binary file gives each point of a legacy VTK file's ``POINTS n TYPE``.
VTK_TYPES = {"bit": 1, "char": 1, "unsigned_char": 1, "short": 2, "unsigned_short": 2,
             "int": 4, "unsigned_int": 4, "long": 8, "unsigned_long": 8, "float": 4,
             "double": 8, "vtktypeint64": 8, "vtkidtype": 8}


def check_mesh_file(path: str | os.PathLike) -> int:
    """Check that the mesh file ``path`` holds what it claims, before a reader sees it.

    Parameters
    ----------
    path : path
        A mesh file; its extension says its format (``.ply``, ``.obj``, ``.stl``, ``.vtk``,
        ``.vtp``/``.vtu``; other formats are only checked for being a non-empty file).

    Returns
    -------
    int
        The file's size in bytes.

    Raises
    ------
    MeshError
        One line naming the file and what is wrong: empty, not a text file where the format
        is text, a header whose counts the file is too small to hold, an OBJ face index out
        of range (or relative, which the reader does not support).
    """
    path = Path(path)
    size = path.stat().st_size
    if size == 0:
        raise MeshError(f"{path}: the file is empty; give a mesh file (OBJ, PLY, STL, VTP)")
    with path.open("rb") as f:
        head = f.read(HEADER_LIMIT)
    suffix = path.suffix.lower()
    check = {".ply": _check_ply, ".obj": _check_obj, ".stl": _check_stl,
             ".vtk": _check_legacy_vtk, ".vtp": _check_xml, ".vtu": _check_xml}.get(suffix)
    if check is not None:
        check(path, head, size)
    return size


def _refuse(path: Path, what: str, way: str = "the file is damaged or not a mesh: export "
            "it again (OBJ, PLY, STL or VTP)") -> MeshError:
    return MeshError(f"{path}: {what}; {way}")


def _check_text(path: Path, head: bytes, size: int, kind: str) -> None:
    _strip_final_nuls(path, head, len(head) >= size, f"where a text {kind} file begins")


def _strip_final_nuls(path: Path, block: bytes, last: bool, where: str = "in a text OBJ "
                      "file") -> bytes:
    """``block`` without the NUL bytes that end a file (some exporters add one); other NUL
    bytes mean binary data where text belongs.
    """
    at = block.find(b"\0")
    if at < 0:
        return block
    if not last or block[at:].strip(b"\0"):
        raise _refuse(path, f"binary data (NUL bytes) {where}")
    return block[:at]


# ---- PLY ---------------------------------------------------------------------------------

def _ply_header(path: Path, head: bytes) -> tuple[str, list, int]:
    """``(format, elements, header bytes)``: each element ``(name, count, properties)`` with
    ``properties`` a list of ``(count type or None, value type, name)``.
    """
    end = re.search(rb"end_header\r?\n", head)
    if not head.startswith(b"ply") or end is None:
        raise _refuse(path, "no PLY header ('ply' ... 'end_header' in its first 64 KiB)")
    fmt, elements = None, []
    for raw in head[:end.start()].decode("ascii", "replace").splitlines()[1:]:
        words = raw.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) >= 2:
            fmt = words[1]
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) == 5 and words[1] == "list" \
                and words[2] in PLY_TYPES and words[3] in PLY_TYPES:
            elements[-1][2].append((words[2], words[3], words[4]))
        elif words[0] == "property" and elements and len(words) == 3 and words[1] in PLY_TYPES:
            elements[-1][2].append((None, words[1], words[2]))
        else:
            raise _refuse(path, f"a PLY header line VTK cannot read: {raw.strip()[:60]!r}")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise _refuse(path, f"an unknown PLY format {fmt!r}")
    return fmt, elements, end.end()


def _check_ply(path: Path, head: bytes, size: int) -> None:
    r"""Element counts against the data's size, and binary faces' indices in range.

    Each element needs at least :math:`\sum_p b_p` bytes in a binary file (a list property
    counts its length's bytes) and :math:`2 n_p` characters in an ASCII one (a digit and a
    separator per property), so a file of :math:`S` bytes after its header holds at most
    :math:`S / \text{that}` of them.
    """
    fmt, elements, start = _ply_header(path, head)
    data = size - start
    need = 0
    for name, count, props in elements:
        each = (sum(PLY_TYPES[c or t] for c, t, _ in props) if fmt != "ascii"
                else 2 * len(props))
        need += count * max(each, 1)
        if need > data:
            raise _refuse(path, f"its header claims {count:,} {name} elements, more than "
                                f"its {size:,} bytes can hold")
    _check_ply_data(path, fmt, elements, start, size)


def _check_ply_data(path: Path, fmt: str, elements: list, start: int, size: int) -> None:
    """Walk the elements: fixed-size ones are skipped in one step, those with lists are read
    (numpy when every list has the same length, else item by item), each list's length
    checked against the data left and each ``vertex_indices`` entry against the vertex count.
    """
    n_vertex = next((count for name, count, _ in elements if name == "vertex"), 0)
    if fmt == "ascii":
        with path.open("rb") as f:
            f.seek(start)
            raw = f.read()
        if _ascii_triangles(path, raw, elements, n_vertex):
            return
        text = raw.decode("ascii", "replace")
        with warnings.catch_warnings():  # a word that is no number ends the data early
            warnings.simplefilter("ignore")
            data = np.fromstring(text, dtype=float, sep=" ")
        where = 0
        for name, count, props in elements:
            where = _ascii_element(path, data, where, name, count, props, n_vertex)
        return
    order = "<" if fmt == "binary_little_endian" else ">"
    raw = np.memmap(path, dtype=np.uint8, mode="r")
    where = start
    for name, count, props in elements:
        where = _binary_element(path, raw, where, order, name, count, props, n_vertex)


def _ascii_triangles(path: Path, raw: bytes, elements: list, n_vertex: int) -> bool:
    r"""The common ASCII layout, checked without parsing the vertices' numbers: fixed-size
    elements, then one element whose only property is a list (``k i_1 .. i_k``, the same
    ``k`` throughout), last. Its words are found as runs of non-blank bytes after the
    :math:`\sum n_e p_e` words before it, and read as integers by Horner's rule; True when
    this layout was found and checked (a bad index raises), False to check another way.
    """
    lists = [i for i, (_, _, props) in enumerate(elements) if any(c for c, _, _ in props)]
    if lists != [len(elements) - 1] or len(elements[-1][2]) != 1:
        return False
    name, count, ((_, _, prop),) = elements[-1]
    skip = sum(n * len(props) for _, n, props in elements[:-1])
    text = np.frombuffer(raw, np.uint8)
    if count == 0 or len(text) == 0:
        return False
    solid = ~_is_blank(text)
    first = np.flatnonzero(solid & ~np.concatenate(([False], solid[:-1])))
    if len(first) <= skip:
        raise _refuse(path, f"the {name} data ends early")
    first = first[skip:]
    values = _whole_numbers(text, solid, first)
    if values is None:
        return False
    k = values[0]
    if not 0 <= k < 1e6 or len(values) != count * (int(k) + 1):
        return False
    rows = values.reshape(count, int(k) + 1)
    if np.any(rows[:, 0] != k):
        return False
    _index_check(path, name, prop, rows[:, 1:], n_vertex)
    return True


def _whole_numbers(text: np.ndarray, solid: np.ndarray, first: np.ndarray):
    """``(len(first),)`` float: the words starting at ``first`` read as whole numbers (an
    optional ``-``, then digits; over 15 digits: infinite), or None if one is not.
    """
    n = len(text)
    negative = text[first] == 45
    start = first + negative
    values, alive = np.zeros(len(first)), np.ones(len(first), bool)
    for j in range(16):
        at = np.minimum(start + j, n - 1)
        more = alive & (start + j < n) & solid[at]
        c = text[at]
        if np.any(more & ((c < 48) | (c > 57))):
            return None  # a word that is no whole number: not this layout
        if j == 0 and not more.all():
            return None
        alive = more
        if not alive.any():
            break
        values = np.where(alive, 10.0 * values + (c.astype(float) - 48.0), values)
    else:
        values[alive] = np.inf
    return np.where(negative, -values, values)


def _index_check(path: Path, name: str, prop: str, values: np.ndarray, n_vertex: int) -> None:
    if prop not in ("vertex_indices", "vertex_index") or len(values) == 0:
        return
    lo, hi = values.min(), values.max()
    if lo < 0 or hi >= n_vertex:
        bad = lo if lo < 0 else hi
        shown = f"{int(bad)}" if np.isfinite(bad) else "beyond 10^15"
        raise _refuse(path, f"a {name} element names vertex {shown}, outside "
                            f"0..{n_vertex - 1}")


def _binary_element(path: Path, raw: np.ndarray, where: int, order: str, name: str,
                    count: int, props: list, n_vertex: int) -> int:
    """The offset after ``count`` binary items of element ``name`` from ``where``."""
    lists = [p for p in props if p[0] is not None]
    fixed = [p for p in props if p[0] is None]
    if not lists:
        return where + count * sum(PLY_TYPES[t] for _, t, _ in fixed)
    if count == 0:
        return where
    fields = []
    for c, t, pname in props:  # try: every list as long as the first item's
        kind = _np_type(order, t)
        if c is None:
            fields.append((pname, kind))
            continue
        off = where + sum(np.dtype(f[1]).itemsize * int(np.prod(f[2]) if len(f) > 2 else 1)
                          for f in fields)
        if off + PLY_TYPES[c] > len(raw):
            raise _refuse(path, f"the {name} data ends early")
        k = int(np.frombuffer(raw[off:off + PLY_TYPES[c]].tobytes(), _np_type(order, c))[0])
        fields += [(f"{pname}#n", _np_type(order, c)), (pname, kind, (k,))]
    row = np.dtype(fields)
    if where + count * row.itemsize <= len(raw):
        items = np.frombuffer(raw, dtype=row, count=count, offset=where)
        same = all(np.all(items[f"{p}#n"] == np.dtype(row[p]).shape[0]) for c, _, p in props
                   if c is not None)
        if same:
            for _, _, p in lists:
                _index_check(path, name, p, items[p], n_vertex)
            return where + count * row.itemsize
    return _binary_items(path, raw, where, order, name, count, props, n_vertex)


def _binary_items(path: Path, raw: np.ndarray, where: int, order: str, name: str,
                  count: int, props: list, n_vertex: int) -> int:
    """Item by item, for lists of varying length (mixed polygons)."""
    import struct

    buf = memoryview(raw)
    end = len(raw)
    for _ in range(count):
        for c, t, pname in props:
            if c is None:
                where += PLY_TYPES[t]
                continue
            size_c = PLY_TYPES[c]
            if where + size_c > end:
                raise _refuse(path, f"the {name} data ends early")
            (k,) = struct.unpack_from(order + _STRUCT[c], buf, where)
            where += size_c
            if k < 0 or where + k * PLY_TYPES[t] > end:
                raise _refuse(path, f"a {name} list of {k} entries runs past the end of "
                                    "the file")
            if pname in ("vertex_indices", "vertex_index") and k:
                _index_check(path, name, pname,
                             np.frombuffer(buf, _np_type(order, t), count=k, offset=where),
                             n_vertex)
            where += k * PLY_TYPES[t]
    if where > end:
        raise _refuse(path, f"the {name} data ends early")
    return where


def _ascii_element(path: Path, data: np.ndarray, where: int, name: str, count: int,
                   props: list, n_vertex: int) -> int:
    """The token after ``count`` ASCII items of element ``name`` from token ``where``."""
    lists = [p for p in props if p[0] is not None]
    if not lists:
        where += count * len(props)
        if where > len(data):
            raise _refuse(path, f"the {name} data ends early")
        return where
    if count == 0:
        return where
    first = _ascii_row(path, data, where, props, name)
    width = first - where
    block = data[where:where + count * width]
    if len(block) == count * width:
        rows = block.reshape(count, width)
        layout, col = [], 0
        for c, _, p in props:
            if c is None:
                col += 1
                continue
            k = int(rows[0, col])
            layout.append((col, k, p))
            col += 1 + k
        if all(np.all(rows[:, col] == k) for col, k, _ in layout):
            for col, k, p in layout:
                _index_check(path, name, p, rows[:, col + 1:col + 1 + k], n_vertex)
            return where + count * width
    for _ in range(count):
        where = _ascii_row(path, data, where, props, name, n_vertex)
    return where


def _ascii_row(path: Path, data: np.ndarray, where: int, props: list, name: str,
               n_vertex: int | None = None) -> int:
    """The token after one ASCII item from ``where``; its indices checked when
    ``n_vertex`` is given.
    """
    for c, _, p in props:
        if where >= len(data):
            raise _refuse(path, f"the {name} data ends early")
        if c is None:
            where += 1
            continue
        k = int(data[where]) if float(data[where]).is_integer() else -1
        if k < 0 or where + 1 + k > len(data):
            raise _refuse(path, f"a {name} list of {k} entries runs past the end of the file")
        if n_vertex is not None and k:
            _index_check(path, name, p, data[where + 1:where + 1 + k], n_vertex)
        where += 1 + k
    return where


#: numpy and struct codes of PLY's types.
_STRUCT = {name: code for names, code in (
    (("char", "int8"), "b"), (("uchar", "uint8"), "B"), (("short", "int16"), "h"),
    (("ushort", "uint16"), "H"), (("int", "int32"), "i"), (("uint", "uint32"), "I"),
    (("float", "float32"), "f"), (("double", "float64"), "d")) for name in names}


def _np_type(order: str, ply_type: str) -> str:
    return order + _STRUCT[ply_type]


# ---- OBJ ---------------------------------------------------------------------------------

def obj_index_ranges(path: str | os.PathLike, chunk: int = 1 << 22) -> dict:
    """Counts and index ranges of an OBJ file, read in chunks of about ``chunk`` bytes.

    Returns
    -------
    dict
        ``"v"``, ``"vt"``, ``"vn"``: how many such lines; ``"max"``: ``(3,)`` the largest
        index in each slot of the ``f``/``l``/``p`` lines (``v/vt/vn``; 0 where none);
        ``"min"``: ``(3,)`` the smallest (negative for relative indices, 0 for an index 0).

    Raises
    ------
    MeshError
        For NUL bytes or a line over ``LINE_LIMIT`` (1 MiB; not a text file: a file of zeros
        named ``.obj`` is refused after its first block, not after reading it all).
    """
    out = {"v": 0, "vt": 0, "vn": 0, "max": np.zeros(3), "min": np.full(3, np.inf)}
    rest = b""
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        while True:
            block = f.read(chunk)
            if not block:
                break
            block = _strip_final_nuls(Path(path), block, f.tell() >= size)
            block = rest + block
            cut = block.rfind(b"\n") + 1
            if cut == 0:
                if len(block) > LINE_LIMIT:
                    raise _refuse(Path(path), f"a line longer than {LINE_LIMIT >> 20} MiB, "
                                              "which no OBJ file has")
                rest = block
                continue
            _scan_obj_block(block[:cut], out)
            rest = block[cut:]
    if rest:
        _scan_obj_block(rest + b"\n", out)
    return out


def _scan_obj_block(block: bytes, out: dict) -> None:
    r"""Add a block of whole OBJ lines to ``out`` (see :func:`obj_index_ranges`).

    A line's keyword is its first characters (leading blanks removed first); an index is a
    run of digits in an ``f``, ``l`` or ``p`` line; its slot 0 after a blank, 2 after
    ``//``, else one more than the run before it; its value by Horner's rule over the run's
    digits :math:`v \leftarrow 10 v + d` (float: exact to 2^53, far beyond any count; runs
    over 15 digits count as infinite).
    """
    text = np.frombuffer(block, np.uint8)
    newline = text == 10
    starts = np.concatenate(([0], np.flatnonzero(newline[:-1]) + 1))
    c0 = text[starts]
    if np.any((c0 == 32) | (c0 == 9)):  # indented lines: rare; drop the indent
        text = np.frombuffer(re.sub(rb"(?m)^[ \t]+", b"", block), np.uint8)
        newline = text == 10
        starts = np.concatenate(([0], np.flatnonzero(newline[:-1]) + 1))
        c0 = text[starts]
    n = len(text)
    c1 = text[np.minimum(starts + 1, n - 1)]
    c2 = text[np.minimum(starts + 2, n - 1)]
    blank1, blank2 = _is_blank(c1), _is_blank(c2)
    is_v = c0 == 118  # "v"
    out["v"] += int(np.count_nonzero(is_v & blank1))
    out["vt"] += int(np.count_nonzero(is_v & (c1 == 116) & blank2))
    out["vn"] += int(np.count_nonzero(is_v & (c1 == 110) & blank2))
    element = ((c0 == 102) | (c0 == 108) | (c0 == 112)) & blank1  # "f", "l", "p"
    if not element.any():
        return
    line = np.cumsum(newline, dtype=np.int32)  # byte i lies on line line[i] - newline[i]
    digit = (text >= 48) & (text <= 57)
    first = np.flatnonzero(digit & ~np.concatenate(([False], digit[:-1])))
    first = first[element[line[first]]]  # a digit's line: no newline at a digit
    if len(first) == 0:
        return
    values, alive = np.zeros(len(first)), np.ones(len(first), bool)
    for k in range(16):
        at = np.minimum(first + k, n - 1)
        alive &= digit[at] & (first + k < n)
        if not alive.any():
            break
        values = np.where(alive, 10.0 * values + (text[at].astype(float) - 48.0), values)
    else:
        values[alive] = np.inf
    p1 = text[np.maximum(first - 1, 0)]
    p2 = text[np.maximum(first - 2, 0)]
    values[p1 == 45] *= -1.0  # "-"
    after_slash = (p1 == 47) | ((p1 == 45) & (p2 == 47))
    double = after_slash & (text[np.maximum(first - 2 - (p1 == 45), 0)] == 47) & \
        (text[np.maximum(first - 1 - (p1 == 45), 0)] == 47)
    slot = np.zeros(len(first), np.int8)
    for _ in range(2):  # a/b/c: b is one after a, c one after b
        slot = np.where(after_slash, np.where(double, 2, np.minimum(
            np.concatenate(([0], slot[:-1])) + 1, 2)), 0).astype(np.int8)
    for s in range(3):
        v = values[slot == s]
        if len(v):
            out["max"][s] = max(out["max"][s], float(v.max()))
            out["min"][s] = min(out["min"][s], float(v.min()))


def _is_blank(c: np.ndarray) -> np.ndarray:
    return (c == 32) | (c == 9) | (c == 13) | (c == 10)


def _check_obj(path: Path, head: bytes, size: int) -> None:
    """A text file whose face indices lie within its ``v``, ``vt`` and ``vn`` counts."""
    _check_text(path, head, size, "OBJ")
    r = obj_index_ranges(path)
    for s, key in enumerate(("v", "vt", "vn")):
        lo, hi = r["min"][s], r["max"][s]
        if np.isinf(lo):
            continue
        if lo < 0:
            raise _refuse(path, f"a face uses a relative (negative) {key} index, which the "
                                "reader does not support", "export it with absolute indices")
        if lo == 0:
            raise _refuse(path, f"a face uses {key} index 0 (OBJ counts from 1)")
        if hi > r[key]:
            raise _refuse(path, f"a face uses {key} index {hi:.0f}, but the file has only "
                                f"{r[key]:,} {key} lines")


# ---- STL, legacy VTK, VTK XML ------------------------------------------------------------

def _check_stl(path: Path, head: bytes, size: int) -> None:
    """A binary STL (not ``solid`` text) holds 84 + 50 n bytes for its n triangles."""
    if head[:5].lower() == b"solid" and b"facet" in head[:1024]:
        _check_text(path, head, size, "STL")
        return
    if size < 84:
        raise _refuse(path, f"a binary STL of {size} bytes, shorter than its 84-byte header")
    n = int(np.frombuffer(head[80:84], "<u4")[0])
    if 84 + 50 * n > size:
        raise _refuse(path, f"its header claims {n:,} triangles, more than its {size:,} "
                            "bytes can hold")


def _check_legacy_vtk(path: Path, head: bytes, size: int) -> None:
    """``POINTS n`` and the cell sections' sizes of a legacy ``.vtk`` file against its size
    (ASCII: at least 2 characters a number; binary: the type's bytes).
    """
    if not head.startswith(b"# vtk DataFile"):
        raise _refuse(path, "no legacy VTK header ('# vtk DataFile ...')")
    binary = b"\nBINARY" in head[:512]
    for m in re.finditer(rb"^(POINTS|POLYGONS|CELLS|TRIANGLE_STRIPS|LINES|VERTICES|"
                         rb"OFFSETS|CONNECTIVITY)\s+(\S+)\s*(\S*)", head, re.M):
        key, a, b = m.group(1).decode(), m.group(2).decode("ascii", "replace"), \
            m.group(3).decode("ascii", "replace").lower()
        if not a.isdigit():
            continue
        n = int(a)
        if key == "POINTS":
            each = 3 * (VTK_TYPES.get(b, 8) if binary else 2)
        elif key in ("OFFSETS", "CONNECTIVITY"):
            each = VTK_TYPES.get(b, 8) if binary else 2
        else:  # POLYGONS n size: size numbers follow
            n = int(b) if b.isdigit() else n
            each = 4 if binary else 2
        if n * each > size:
            raise _refuse(path, f"its {key} section claims {n:,} numbers, more than its "
                                f"{size:,} bytes can hold")


def _check_xml(path: Path, head: bytes, size: int) -> None:
    """``NumberOfPoints``/``NumberOfPolys``/``NumberOfCells`` of a VTK XML file against its
    size (at least 2 bytes a point or cell, however it is encoded or compressed: zlib's
    best ratio is about 1000:1, so a count above 1000 times the file's size is impossible).
    """
    for m in re.finditer(rb'NumberOf(Points|Polys|Cells|Strips|Lines|Verts)="([^"]*)"', head):
        n = m.group(2).decode("ascii", "replace").strip()
        if not n.isdigit():
            raise _refuse(path, f"NumberOf{m.group(1).decode()}={n[:20]!r} is not a count")
        if int(n) > 1000 * size:
            raise _refuse(path, f"it claims {int(n):,} {m.group(1).decode().lower()}, more "
                                f"than its {size:,} bytes can hold")


# ---- quiet reading -----------------------------------------------------------------------

@contextmanager
def quiet_vtk() -> Iterator[None]:
    """Keep VTK's output window, VTK's logger and PyVista's warnings quiet inside the block.

    The caller turns a failed read into one line of its own; what VTK would have printed
    (10-27 lines of errors, object dumps and colour codes) is dropped.
    """
    import vtkmodules.vtkCommonCore as vcc

    obj, logger = vcc.vtkObject, vcc.vtkLogger
    display = obj.GetGlobalWarningDisplay()
    verbosity = logger.GetCurrentVerbosityCutoff()
    obj.GlobalWarningDisplayOff()
    logger.SetStderrVerbosity(logger.VERBOSITY_OFF)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        obj.SetGlobalWarningDisplay(display)
        logger.SetStderrVerbosity(verbosity)


def quiet_read(path: str | os.PathLike):
    """``pyvista.read(path)`` inside :func:`quiet_vtk`: for read-back checks, whose caller
    reports a failure in one line of its own.
    """
    import pyvista as pv

    with quiet_vtk():
        return pv.read(path)
