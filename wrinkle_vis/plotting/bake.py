"""Baking the wrinkles of a skin with UVs into texture maps (no Qt).

A texel belongs to the skin triangle whose UV triangle covers its centre; every map is the
barycentric interpolation of per-vertex (or per-corner) values at the texel centres, so a
map sampled back at its texel centres gives the mesh's own values. Texels outside every UV
island but within ``padding`` texels of one take the values of the nearest covered texel
(dilation), so filtering and mip-mapping across a UV seam do not pull in the background.

Images follow the OBJ and Blender convention: ``v`` points up, so image row 0 is
``v = 1``; texel ``(i, j)`` (column, row) has its centre at
``u = (i + 0.5) / width``, ``v = 1 - (j + 0.5) / height``.

Maps (:func:`bake_maps`, written by :func:`save_bake`)
------------------------------------------------------
``displacement.png``, ``displacement.json``
    W as a 16-bit grey PNG: ``W = offset + scale * value / 65535`` in the face's units,
    with ``offset`` and ``scale`` in the JSON (and Blender's Displace modifier settings:
    ``midlevel = -offset / scale``, ``strength = scale``). Background: W = 0.
``normal.png``, ``normal.json``
    The wrinkles as a tangent-space normal map (16-bit RGB, ``rgb = 65535 (n + 1) / 2``:
    the wrinkles tilt the normal by a few degrees, and 8 bits would band them in steps
    of about 0.45 degrees):
    the final skin's normal in the frame of the smooth deformed skin (the expression
    without its wrinkles), x along +u, y along +v (OpenGL's and Blender's convention,
    "green up"), z along the normal. Flat skin is ``(32768, 32768, 65535)``.
``field_<name>.png``, ``field_<name>.json``
    A field as colours (8-bit RGBA) with the colour map and range of
    :mod:`wrinkle_vis.plotting.fields`, undefined values in
    :data:`~wrinkle_vis.plotting.fields.NAN_COLOR`, transparent outside the islands and
    their padding. ``<name>`` is the point-array name (``W``, ``corrugator_L__eps``).
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ..core.face import FaceState
from ..core.files import (
    OutputPathError,
    WriteError,
    resolve_output,
    temp_folder,
    umask,
    write_error,
)
from ..core.mesh import MeshError, TriangleSurface, unit_rows
from .fields import NAN_COLOR, field_info, field_range
from .finite import require_finite
from .polydata import field_array_name
from .writers import Written, _write_synced, replace_folder

__all__ = ["BAKE_FILE", "BakedMaps", "UVError", "UVRaster", "bake_maps", "check_bake_folder",
           "check_corner_uvs",
           "decode_displacement", "read_obj_uvs", "sample_bilinear", "save_bake",
           "tangent_space_normals", "uv_raster"]

#: The names of the files :func:`save_bake` writes (a folder holding others is refused).
BAKE_FILE = re.compile(r"(displacement|normal|field_[^/\\]+)\.(png|json)")
#: The largest number of 2D points a rasterization chunk handles at once.
_CHUNK = 1 << 21


class UVError(MeshError):
    """A skin whose file has no UV coordinates, or UVs that do not fit its triangles."""


# ---------------------------------------------------------------------- UVs from OBJ
def _obj_index(token: bytes, count: int) -> int:
    i = int(token)
    return count + i if i < 0 else i - 1


def _parse_obj(path: Path):
    """Vertices ``(N, 3)``, texture coordinates ``(K, 2)`` and the polygons (lists of
    vertex indices and of UV indices, -1 where a corner has none). The file is checked first
    (:func:`~wrinkle_vis.datasets.meshfile.check_mesh_file`: text, indices in range).
    """
    from ..datasets.meshfile import check_mesh_file

    check_mesh_file(path)
    vs, vts, polys = [], [], []
    with open(path, "rb") as fh:
        for raw in fh:
            line = raw.strip()
            if line.startswith(b"v "):
                vs.append([float(x) for x in line.split()[1:4]])
            elif line.startswith(b"vt "):
                parts = line.split()[1:3]
                vts.append([float(parts[0]), float(parts[1]) if len(parts) > 1 else 0.0])
            elif line.startswith(b"f "):
                corners = [c.split(b"/") for c in line.split()[1:]]
                v = [_obj_index(c[0], len(vs)) for c in corners]
                t = [_obj_index(c[1], len(vts)) if len(c) > 1 and c[1] else -1
                     for c in corners]
                polys.append((v, t))
    return np.asarray(vs, float).reshape(-1, 3), np.asarray(vts, float).reshape(-1, 2), polys


def _triples(k: int) -> list[tuple[int, int, int]]:
    """Corner triples of a ``k``-gon that a triangulation may use: all of them up to a
    hexagon (either diagonal of a quad), a fan beyond.
    """
    from itertools import combinations

    return list(combinations(range(k), 3)) if k <= 6 else [(0, i, i + 1)
                                                          for i in range(1, k - 1)]


def read_obj_uvs(path: str | os.PathLike, surface: TriangleSurface) -> np.ndarray:
    """``(m, 3, 2)``: the UV coordinates of every corner of ``surface``'s triangles, read
    from the OBJ file it was loaded from.

    :func:`~wrinkle_vis.datasets.read_surface` welds the vertices an OBJ reader splits
    along UV seams and drops the UVs; here every triangle of the welded ``surface`` is
    matched to the OBJ polygon with the same three vertices (by position), and each corner
    takes the ``vt`` of its vertex in that polygon, so a vertex on a seam has one UV per
    side. Triangulated quads match whichever diagonal the reader chose.

    Raises
    ------
    UVError
        If the file is not an OBJ, has no ``vt``, or some triangles have no UVs or no
        polygon of the file (naming how many, and the way out).
    """
    path = Path(path)
    if path.suffix.lower() != ".obj":
        raise UVError(f"{path}: UV coordinates are read from OBJ files (vt lines); export "
                      "the skin with its UVs as OBJ")
    vs, vts, polys = _parse_obj(path)
    if len(vts) == 0:
        raise UVError(f"{path}: the file has no UV coordinates (vt lines); unwrap the skin "
                      "(e.g. in Blender: UV > Smart UV Project) and export it as OBJ")
    # the OBJ's vertices by position (an OBJ may repeat a position), and the skin's
    unique, canon = np.unique(vs.astype(np.float32), axis=0, return_inverse=True)
    canon = canon.ravel()
    extent = float(np.ptp(unique, axis=0).max()) or 1.0
    dist, nearest = cKDTree(unique).query(surface.points)
    if dist.max() > 1e-5 * extent:
        raise UVError(f"{path}: {int((dist > 1e-5 * extent).sum())} skin vertices are not "
                      "vertices of the file; load the skin from this file unchanged")
    keys, uv_ids = [], []
    for v, t in polys:
        cv = canon[v]
        for a, b, c in _triples(len(v)):
            order = np.argsort(cv[[a, b, c]], kind="stable")
            corner = np.array([a, b, c])[order]
            keys.append(cv[corner])
            uv_ids.append(np.asarray(t)[corner])
    keys = np.asarray(keys, np.int64).reshape(-1, 3)
    uv_ids = np.asarray(uv_ids, np.int64).reshape(-1, 3)
    base = int(len(unique)) + 1
    packed = (keys[:, 0] * base + keys[:, 1]) * base + keys[:, 2]
    sort = np.argsort(packed, kind="stable")
    packed, uv_ids = packed[sort], uv_ids[sort]
    tri = nearest[surface.triangles]  # (m, 3) canonical vertices of each skin triangle
    order = np.argsort(tri, axis=1, kind="stable")
    tri_sorted = np.take_along_axis(tri, order, axis=1)
    want = (tri_sorted[:, 0] * base + tri_sorted[:, 1]) * base + tri_sorted[:, 2]
    at = np.clip(np.searchsorted(packed, want), 0, len(packed) - 1)
    found = packed[at] == want
    ids_sorted = uv_ids[at]
    ids = np.empty_like(ids_sorted)
    np.put_along_axis(ids, order, ids_sorted, axis=1)  # back to the triangle's corners
    missing = ~found | (ids < 0).any(axis=1)
    if missing.any():
        raise UVError(f"{path}: {int(missing.sum())} of {surface.n_triangles} skin triangles "
                      "have no UVs in the file; give every face of the OBJ its vt")
    return check_corner_uvs(vts[ids], str(path))


def check_corner_uvs(corner_uvs: np.ndarray, where: str,
                     size: tuple[int, int] | None = None) -> np.ndarray:
    r"""``corner_uvs`` ``(m, 3, 2)`` if they can be baked: finite, and their triangles
    covering some of the map, :math:`\tfrac12 \sum |\det(b - a, c - a)| \, w h \ge 1`
    texel at ``size`` ``(w, h)`` (without ``size``: a non-zero area).

    Raises
    ------
    UVError
        One line naming ``where``: NaN or infinite UVs, or UVs all equal or in a line.
    """
    uv = np.asarray(corner_uvs, float)
    bad = ~np.isfinite(uv).all(axis=(1, 2))
    if bad.any():
        raise UVError(f"{where}: {int(bad.sum())} of {len(uv)} triangles have UV coordinates "
                      "that are not finite (NaN or infinity); unwrap the skin again (e.g. in "
                      "Blender: UV > Smart UV Project) and export it as OBJ")
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    area = 0.5 * float(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum())
    texels = area * (size[0] * size[1] if size is not None else 1.0)
    if not texels >= (1.0 if size is not None else 1e-300):
        covers = (f"cover {texels:.2g} texels of the {size[0]} x {size[1]} map"
                  if size is not None else "have no area (all equal, or in a line)")
        raise UVError(f"{where}: the UV triangles {covers}, so nothing can be baked; "
                      "unwrap the skin (e.g. in Blender: UV > Smart UV Project) and export "
                      "it as OBJ")
    return uv


# ---------------------------------------------------------------------- rasterization
@dataclass(frozen=True)
class UVRaster:
    """Which triangle each texel centre falls in, and where.

    Attributes
    ----------
    shape : (int, int)
        ``(height, width)`` in texels.
    texel : (k,) int
        Flat indices (``row * width + column``) of the texels that have values: those
        inside a UV triangle, then the padding.
    triangle : (k,) int
        The triangle of each (for padding, the nearest covered texel's).
    bary : (k, 3) float
        Barycentric coordinates of each texel centre in its triangle.
    covered : (k,) bool
        Inside its triangle (False for padding).
    """

    shape: tuple[int, int]
    texel: np.ndarray
    triangle: np.ndarray
    bary: np.ndarray
    covered: np.ndarray

    def interpolate(self, corner_values: np.ndarray) -> np.ndarray:
        """``(k, ...)``: per-corner values ``(m, 3, ...)`` at the texels."""
        v = np.asarray(corner_values)[self.triangle]
        return np.einsum("kj,kj...->k...", self.bary, v)

    def image(self, values: np.ndarray, background) -> np.ndarray:
        """``(h, w, ...)``: ``values`` ``(k, ...)`` put at their texels, ``background``
        elsewhere.
        """
        values = np.asarray(values)
        out = np.empty((self.shape[0] * self.shape[1], *values.shape[1:]), values.dtype)
        out[...] = background
        out[self.texel] = values
        return out.reshape(*self.shape, *values.shape[1:])


def _texel_coordinates(uv: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Continuous texel coordinates ``(x, y)`` of UVs, texel centres at whole numbers."""
    w, h = size
    return uv[..., 0] * w - 0.5, (1.0 - uv[..., 1]) * h - 0.5


def uv_raster(corner_uvs: np.ndarray, size: tuple[int, int], padding: int = 8,
              progress: Callable[[Iterable], Iterable] | None = None) -> UVRaster:
    """Rasterize the UV triangles ``corner_uvs`` ``(m, 3, 2)`` at ``size`` ``(width,
    height)`` texels, with ``padding`` texels of dilation around every island.

    A texel centre on an edge shared by two triangles goes to one of them (the later);
    overlapping islands are resolved the same way. ``progress`` wraps the iterable of
    chunks (e.g. ``tqdm``).
    """
    w, h = int(size[0]), int(size[1])
    uv = np.asarray(corner_uvs, float)
    x, y = _texel_coordinates(uv, (w, h))
    x0 = np.clip(np.ceil(x.min(axis=1)), 0, w).astype(np.int64)
    x1 = np.clip(np.floor(x.max(axis=1)), -1, w - 1).astype(np.int64)
    y0 = np.clip(np.ceil(y.min(axis=1)), 0, h).astype(np.int64)
    y1 = np.clip(np.floor(y.max(axis=1)), -1, h - 1).astype(np.int64)
    nx, ny = np.maximum(x1 - x0 + 1, 0), np.maximum(y1 - y0 + 1, 0)
    det = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    count = np.where(np.abs(det) > 1e-12, nx * ny, 0)
    ids = np.flatnonzero(count)
    ends = np.cumsum(count[ids])
    cuts = np.searchsorted(ends, np.arange(_CHUNK, ends[-1] if len(ends) else 0, _CHUNK))
    owner = np.full(w * h, -1, np.int32)
    bary = np.zeros((w * h, 2), np.float64)
    for chunk in (progress or (lambda c: c))(np.split(ids, cuts)):
        if len(chunk) == 0:
            continue
        c = count[chunk]
        tri = np.repeat(chunk, c)
        local = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        px = x0[tri] + local % nx[tri]
        py = y0[tri] + local // nx[tri]
        xa, ya = x[tri, 0], y[tri, 0]
        dx, dy = px - xa, py - ya
        l1 = (dx * (y[tri, 2] - ya) - (x[tri, 2] - xa) * dy) / det[tri]
        l2 = ((x[tri, 1] - xa) * dy - dx * (y[tri, 1] - ya)) / det[tri]
        inside = (l1 >= -1e-9) & (l2 >= -1e-9) & (l1 + l2 <= 1 + 1e-9)
        flat = (py * w + px)[inside]
        owner[flat] = tri[inside]
        bary[flat, 0], bary[flat, 1] = l1[inside], l2[inside]
    covered = owner >= 0
    texel = np.flatnonzero(covered)
    pad = np.zeros(0, np.int64)
    if padding > 0 and texel.size:
        from scipy.ndimage import distance_transform_edt

        dist, (iy, ix) = distance_transform_edt(~covered.reshape(h, w), return_indices=True)
        near = (dist > 0) & (dist <= padding)
        pad = np.flatnonzero(near.ravel())
        source = (iy * w + ix).ravel()[pad]
        owner[pad], bary[pad] = owner[source], bary[source]
    texel = np.concatenate([texel, pad])
    b = bary[texel]
    return UVRaster((h, w), texel, owner[texel].astype(np.int64),
                    np.column_stack([1.0 - b[:, 0] - b[:, 1], b]),
                    np.arange(len(texel)) < len(texel) - len(pad))


# ---------------------------------------------------------------------- maps
@dataclass
class BakedMaps:
    """Baked images and their JSON side files, by file name (see :func:`save_bake`).

    Attributes
    ----------
    images : dict of str to ndarray
        ``"displacement.png"``: ``(h, w) uint16``; ``"normal.png"``: ``(h, w, 3) uint16``;
        ``"field_<name>.png"``: ``(h, w, 4) uint8``.
    sidecars : dict of str to dict
        The JSON beside each image (``"displacement.json"``, ...).
    check : dict
        W sampled back from the 16-bit map: the largest error at the covered texel centres
        and, sampled bilinearly at every corner's UV, the largest and the 99th percentile,
        as fractions of W's range.
    """

    images: dict[str, np.ndarray] = field(default_factory=dict)
    sidecars: dict[str, dict] = field(default_factory=dict)
    check: dict[str, float] = field(default_factory=dict)


def decode_displacement(image: np.ndarray, meta: dict) -> np.ndarray:
    """W from a 16-bit displacement map and its JSON: ``offset + scale * value / 65535``."""
    return meta["offset"] + meta["scale"] * np.asarray(image, float) / 65535.0


def sample_bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``(p, ...)``: ``image`` ``(h, w, ...)`` sampled bilinearly at ``uv`` ``(p, 2)``
    (``v`` up, texel centres as in the module's notes, edges clamped).
    """
    image = np.asarray(image, float)
    h, w = image.shape[:2]
    x, y = _texel_coordinates(np.asarray(uv, float), (w, h))
    x, y = np.clip(x, 0, w - 1), np.clip(y, 0, h - 1)
    i0, j0 = np.floor(x).astype(int), np.floor(y).astype(int)
    i1, j1 = np.minimum(i0 + 1, w - 1), np.minimum(j0 + 1, h - 1)
    fx, fy = x - i0, y - j0
    shape = (-1,) + (1,) * (image.ndim - 2)
    fx, fy = fx.reshape(shape), fy.reshape(shape)
    top = image[j0, i0] * (1 - fx) + image[j0, i1] * fx
    bottom = image[j1, i0] * (1 - fx) + image[j1, i1] * fx
    return top * (1 - fy) + bottom * fy


def _corner_tangents(points: np.ndarray, triangles: np.ndarray,
                     corner_uvs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(m, 3, 3)`` twice: the directions of +u and +v on the surface at every corner,
    area-weighted over the triangles that share the corner's vertex and UV (so they are
    smooth within a UV island and independent on either side of a seam).
    """
    p = points[triangles]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = corner_uvs[:, 1] - corner_uvs[:, 0], corner_uvs[:, 2] - corner_uvs[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    ok = np.abs(det) > 1e-20
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    t = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * inv  # dP/du
    b = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * inv  # dP/dv
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)[:, None]
    t, b = unit_rows(t) * area, unit_rows(b) * area
    key = np.column_stack([triangles.reshape(-1).astype(float), corner_uvs.reshape(-1, 2)])
    _, group = np.unique(key, axis=0, return_inverse=True)
    group = group.ravel()
    n_groups = int(group.max()) + 1
    sums = []
    for per_tri in (t, b):
        corner = np.repeat(per_tri, 3, axis=0)
        acc = np.zeros((n_groups, 3))
        np.add.at(acc, group, corner)
        sums.append(acc[group].reshape(-1, 3, 3))
    return sums[0], sums[1]


def tangent_space_normals(raster: UVRaster, points: np.ndarray, triangles: np.ndarray,
                          corner_uvs: np.ndarray, base_normals: np.ndarray,
                          final_normals: np.ndarray, chunk: int = 1 << 20) -> np.ndarray:
    r"""``(k, 3)``: unit ``final_normals`` in the tangent frames of a base surface, at the
    texels of ``raster``.

    Parameters
    ----------
    raster : UVRaster
        The texels (:func:`uv_raster`).
    points : (n, 3) float
        The base surface (the one the map will be applied to).
    triangles : (m, 3) int
        Its triangles.
    corner_uvs : (m, 3, 2) float
        Their UVs.
    base_normals, final_normals : (n, 3) float
        Vertex normals of the base surface and of the detailed one.

    Notes
    -----
    At a texel, :math:`N` is the interpolated base normal, :math:`T` the interpolated
    direction of +u (area-weighted over the triangles that share the corner's vertex and
    UV) made orthogonal to :math:`N`, and :math:`B = \pm N \times T`, the sign that of +v
    (so mirrored islands work). The result is
    :math:`(f \cdot T, f \cdot B, f \cdot N)` for the interpolated unit final normal
    :math:`f`: OpenGL's convention, green up.
    """
    corner_t, corner_b = _corner_tangents(np.asarray(points, float), triangles,
                                          np.asarray(corner_uvs, float))
    out = np.empty((len(raster.texel), 3))
    for s in range(0, len(raster.texel), chunk):
        part = UVRaster(raster.shape, raster.texel[s:s + chunk],
                        raster.triangle[s:s + chunk], raster.bary[s:s + chunk],
                        raster.covered[s:s + chunk])
        n = unit_rows(part.interpolate(base_normals[triangles]))
        t = part.interpolate(corner_t)
        t = unit_rows(t - np.einsum("ij,ij->i", t, n)[:, None] * n)
        b = np.cross(n, t)
        flip = np.einsum("ij,ij->i", b, part.interpolate(corner_b)) < 0
        b[flip] *= -1
        f = unit_rows(part.interpolate(final_normals[triangles]))
        out[s:s + chunk] = np.column_stack([np.einsum("ij,ij->i", f, t),
                                            np.einsum("ij,ij->i", f, b),
                                            np.einsum("ij,ij->i", f, n)])
    return out


def _colours(values: np.ndarray, cmap: str, clim: tuple[float, float]) -> np.ndarray:
    """``(k, 4) uint8``: ``values`` through a Matplotlib colour map, NaN in NAN_COLOR."""
    import matplotlib

    lo, hi = clim
    rgba = matplotlib.colormaps[cmap](np.clip((values - lo) / (hi - lo), 0.0, 1.0))
    nan = np.isnan(values)
    rgba[nan] = matplotlib.colors.to_rgba(NAN_COLOR)
    return np.round(rgba * 255).astype(np.uint8)


def bake_maps(state: FaceState, corner_uvs: np.ndarray, size: tuple[int, int] = (1024, 1024),
              *, fields: Sequence[tuple[str, str | None]] = (("W", None),), padding: int = 8,
              unit: str = "mm", progress: Callable[[Iterable], Iterable] | None = None,
              info: dict | None = None) -> BakedMaps:
    """Bake ``state``'s wrinkles into a displacement map, a normal map and colour maps.

    Parameters
    ----------
    state : FaceState
        The evaluated expression (its skin must be the one ``corner_uvs`` belong to).
    corner_uvs : (m, 3, 2) float
        UVs of every corner of the skin's triangles (:func:`read_obj_uvs`).
    size : (int, int)
        ``(width, height)`` in texels.
    fields : sequence of (str, str or None)
        The fields to bake as colour maps: ``(field, muscle)``, ``muscle`` None for W's
        total.
    padding : int
        Texels of dilation around every UV island.
    unit : str
        The unit of the face's lengths, recorded in the JSON.
    progress : callable, optional
        Wraps an iterable of steps (e.g. ``tqdm``).
    info : dict, optional
        More to record in every JSON (the expression, the intensity).

    Returns
    -------
    BakedMaps
        The images, their JSON side files, and W sampled back (``check``).
    """
    require_finite("the baked maps", state)
    skin = state.face.skin
    corner_uvs = np.asarray(corner_uvs, float)
    if corner_uvs.shape != (skin.n_triangles, 3, 2):
        raise ValueError(f"corner_uvs is {corner_uvs.shape}; expected "
                         f"({skin.n_triangles}, 3, 2)")
    check_corner_uvs(corner_uvs, "the skin's UVs", (int(size[0]), int(size[1])))
    common = {**(info or {}), "size": [int(size[0]), int(size[1])], "padding": int(padding),
              "uv_origin": "bottom left (v up, as OBJ and Blender): image row 0 is v = 1"}
    out = BakedMaps()
    holder: dict = {}  # the raster, made by the first step
    steps = [lambda: holder.update(r=uv_raster(corner_uvs, size, padding)),
             lambda: _bake_displacement(holder["r"], state, corner_uvs, unit, common, out),
             lambda: _bake_normal(holder["r"], state, corner_uvs, common, out)]
    steps += [lambda f=f, m=m: _bake_colour(holder["r"], state, corner_uvs, f, m, unit,
                                            common, out) for f, m in fields]
    for step in (progress or (lambda s: s))(steps):
        step()
    return out


def _bake_displacement(r, state: FaceState, corner_uvs: np.ndarray, unit: str, common: dict,
                       out: BakedMaps) -> None:
    """W as a 16-bit displacement map on raster ``r`` into ``out``, with its scale and
    offset in its JSON and W sampled back (``out.check``).
    """
    tris = state.face.skin.triangles
    W = np.asarray(state.W, float)
    offset = min(float(W.min()), 0.0)
    scale = max(float(W.max()), 0.0) - offset
    at = r.interpolate(W[tris])
    q = np.round((at - offset) / scale * 65535) if scale > 0 else np.zeros_like(at)
    q = np.clip(q, 0, 65535).astype(np.uint16)
    zero = np.uint16(round(-offset / scale * 65535) if scale > 0 else 0)
    image = r.image(q, zero)
    meta = {"map": "displacement.png", "field": "W", "unit": unit, "offset": offset,
            "scale": scale, "decode": "W = offset + scale * value / 65535",
            "blender_displace": {"midlevel": -offset / scale if scale > 0 else 0.0,
                                 "strength": scale},
            **common}
    out.check = _sampled_back(r, W, tris, corner_uvs, at, q, image, meta)
    meta["sampled_back"] = {"texel_centres_max_fraction_of_range":
                            out.check["texel_centres_max"],
                            "corners_bilinear_p99_fraction_of_range":
                            out.check["corners_p99"]}
    out.images["displacement.png"] = image
    out.sidecars["displacement.json"] = meta


def _sampled_back(r, W: np.ndarray, tris: np.ndarray, corner_uvs: np.ndarray, at, q, image,
                  meta: dict) -> dict[str, float]:
    """How far the displacement map decodes from W, as fractions of W's range: at the
    texel centres (``q`` against the interpolated ``at``) and bilinearly sampled at the
    triangles' corners (the largest and the 99th percentile).
    """
    decoded = decode_displacement(q[r.covered], meta)
    span = float(W.max() - W.min()) or 1.0
    at_corners = sample_bilinear(decode_displacement(image, meta), corner_uvs.reshape(-1, 2))
    corner_err = np.abs(at_corners - W[tris].ravel()) / span
    return {"texel_centres_max": float(np.abs(decoded - at[r.covered]).max() / span)
            if r.covered.any() else 0.0,
            "corners_max": float(corner_err.max()),
            "corners_p99": float(np.percentile(corner_err, 99))}


def _bake_normal(r, state: FaceState, corner_uvs: np.ndarray, common: dict,
                 out: BakedMaps) -> None:
    """The wrinkles' tangent-space normal map (16 bits, OpenGL) on raster ``r`` into
    ``out``.
    """
    skin = state.face.skin
    deformed = np.asarray(state.deformed_points, float)
    ts = tangent_space_normals(r, deformed, skin.triangles, corner_uvs,
                               state.shading_normals(deformed), np.asarray(state.normals))
    rgb = np.clip(np.round((ts + 1.0) * 32767.5), 0, 65535).astype(np.uint16)
    out.images["normal.png"] = r.image(rgb, np.array([32768, 32768, 65535], np.uint16))
    out.sidecars["normal.json"] = {
        "map": "normal.png", "space": "tangent", "bit_depth": 16,
        "convention": "OpenGL (green up): x along +u, y along +v, z along the normal",
        "encode": "rgb = 65535 (n + 1) / 2",
        "base": "the smooth deformed skin (the expression without its wrinkles)",
        **common}


def _bake_colour(r, state: FaceState, corner_uvs: np.ndarray, fname: str,
                 muscle: str | None, unit: str, common: dict, out: BakedMaps) -> None:
    """Field ``fname`` of ``muscle`` as a colour map on raster ``r`` into ``out``."""
    tris = state.face.skin.triangles
    values = np.asarray(state.field_values(fname, muscle), float)
    fi = field_info(fname)
    clim = field_range(fi, values)
    name = field_array_name(fname, muscle)
    rgba = _colours(r.interpolate(values[tris]), fi.cmap, clim)
    out.images[f"field_{name}.png"] = r.image(rgba, np.zeros(4, np.uint8))
    out.sidecars[f"field_{name}.json"] = {
        "map": f"field_{name}.png", "field": fname, "muscle": muscle, "cmap": fi.cmap,
        "range": list(clim), "unit": unit if fi.unit == "length" else fi.unit,
        "nan_colour": NAN_COLOR, "background": "transparent", **common}


# ---------------------------------------------------------------------- writing
def check_bake_folder(path: str | os.PathLike) -> Path:
    """Check, before any work, that ``path`` can be (re)written as a folder of maps.

    Returns
    -------
    Path
        The folder, symbolic links in its parent resolved.

    Raises
    ------
    OutputPathError
        If ``path`` is a file or a link, holds files other than baked maps, or its parent
        folder is missing or read-only.
    """
    given = Path(path).expanduser()
    if str(given) in ("", "."):
        raise OutputPathError("no output folder given; name one, e.g. 'maps'")
    if given.is_symlink() or (given.exists() and not given.is_dir()):
        raise OutputPathError(f"{str(given)!r} is not a folder; the maps go in a folder of "
                              "that name: move it or choose another name")
    real = resolve_output(given.parent) / given.name  # not through others' links
    parent = real.parent
    if not parent.is_dir():
        raise OutputPathError(f"folder {str(parent)!r} does not exist; create it first "
                              f"(mkdir -p {parent}) or write somewhere else")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputPathError(f"folder {str(parent)!r} is not writable; write somewhere else "
                              "or make it writable")
    if real.is_dir():
        others = [p.name for p in real.iterdir()
                  if not (p.is_file() and BAKE_FILE.fullmatch(p.name))]
        if others:
            raise OutputPathError(
                f"folder {str(given)!r} holds other files ({', '.join(sorted(others)[:3])}); "
                "the maps replace the folder whole: choose a new or an empty folder")
    return real


def _png_bytes(image: np.ndarray) -> bytes:
    from PIL import Image

    image = np.ascontiguousarray(image)
    if image.dtype == np.uint16 and image.ndim == 3:
        return _rgb16_png_bytes(image)
    buffer = BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")
    return buffer.getvalue()


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    import zlib

    return (len(data).to_bytes(4, "big") + kind + data
            + zlib.crc32(kind + data).to_bytes(4, "big"))


def _rgb16_png_bytes(image: np.ndarray) -> bytes:
    """A 16-bit RGB PNG of ``image`` ``(h, w, 3) uint16`` (Pillow writes none): big-endian
    samples, each row with filter type 0, zlib-compressed.
    """
    import zlib

    h, w, _ = image.shape
    rows = np.zeros((h, 1 + 6 * w), np.uint8)
    rows[:, 1:] = image.astype(">u2").view(np.uint8).reshape(h, 6 * w)
    header = w.to_bytes(4, "big") + h.to_bytes(4, "big") + bytes([16, 2, 0, 0, 0])
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", header)
            + _png_chunk(b"IDAT", zlib.compress(rows.tobytes(), 6))
            + _png_chunk(b"IEND", b""))


def _read_rgb16_png(data: bytes) -> np.ndarray:
    """``(h, w, 3) uint16`` from a PNG as :func:`_rgb16_png_bytes` writes it (its CRCs
    checked; any other filter than 0 is refused).
    """
    import zlib

    pos, header, idat = 8, None, []
    while pos < len(data):
        n = int.from_bytes(data[pos:pos + 4], "big")
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        if zlib.crc32(kind + body) != int.from_bytes(data[pos + 8 + n:pos + 12 + n], "big"):
            raise ValueError(f"bad CRC in the {kind!r} chunk")
        header = body if kind == b"IHDR" else header
        if kind == b"IDAT":
            idat.append(body)
        pos += 12 + n
    w, h = int.from_bytes(header[:4], "big"), int.from_bytes(header[4:8], "big")
    if header[8:10] != bytes([16, 2]):
        raise ValueError("not a 16-bit RGB PNG")
    rows = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8).reshape(h, 1 + 6 * w)
    if rows[:, 0].any():
        raise ValueError("a row filter other than 0")
    return rows[:, 1:].copy().view(">u2").reshape(h, w, 3).astype(np.uint16)


def _read_png(path: Path) -> np.ndarray:
    from PIL import Image

    data = path.read_bytes()
    if data[24:26] == bytes([16, 2]):  # the IHDR's bit depth and colour type
        return _read_rgb16_png(data)
    with Image.open(BytesIO(data)) as im:
        return np.asarray(im)


def save_bake(maps: BakedMaps, folder: str | os.PathLike) -> Written:
    """Write ``maps`` into ``folder`` (PNG images and their JSON), replacing it whole.

    The files are written to a hidden folder beside it, read back and compared, then the
    folder is swapped in; on a failure the old folder is as it was.

    Raises
    ------
    OutputPathError
        From :func:`check_bake_folder`.
    WriteError
        If writing failed or an image does not read back the same.
    """
    real = check_bake_folder(folder)
    try:
        work = temp_folder(real.parent, real.name)
    except OSError as exc:
        raise write_error(real, exc) from exc
    try:
        new = work / real.name
        try:
            new.mkdir()
            for name, image in maps.images.items():
                _write_synced(new / name, _png_bytes(image))
            for name, meta in maps.sidecars.items():
                _write_synced(new / name, (json.dumps(meta, indent=2) + "\n").encode())
            for name in new.iterdir():
                os.chmod(name, 0o666 & ~umask())
        except OSError as exc:
            raise write_error(real, exc) from exc
        for name, image in maps.images.items():
            try:
                same = np.array_equal(_read_png(new / name), image)
            except Exception:  # unreadable: as wrong as different
                same = False
            if not same:
                raise WriteError(f"could not write {str(real)!r}: {name} does not read back "
                                 "the same; nothing was changed there")
        try:
            replace_folder(new, real)
        except OSError as exc:
            raise write_error(real, exc) from exc
    finally:
        shutil.rmtree(work, ignore_errors=True)
    h, w = next(iter(maps.images.values())).shape[:2]
    return Written(real, f"{len(maps.images)} maps of {w} by {h} texels "
                         f"({', '.join(maps.images)})")
