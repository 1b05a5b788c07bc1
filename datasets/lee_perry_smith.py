"""The Lee Perry-Smith head: a real head scan as a built-in face.

``wv.datasets.load_face("lee_perry_smith")`` returns it: the skin of the scan welded along
its UV seams, in millimetres, in the built-in face's frame (y up, the face towards +z,
x towards the subject's left, the origin between the eyes), with its UV coordinates
(:func:`lee_perry_smith_uvs`), a closed skull inside it (the level set of
:func:`~wrinkle_vis.datasets.skull.scan_skull`) and 21 muscles with the procedural face's
names, moved onto it from nine landmarks (:func:`~wrinkle_vis.datasets.scans.transfer_layout`)
and fitted to its forehead (``scripts/write_lee_perry_smith.py``).

The package ships a derived, compact form of the scan (``lee_perry_smith.npz``: float32
points and uint32 triangles of the skin and the skull, the UV table and each corner's
index into it) and its layout (``lee_perry_smith.json``), both written by
``scripts/write_lee_perry_smith.py`` from ``../shared/realmeshes/lee_perry_smith_head.obj``.

Licence and credit: "Infinite, 3D Head Scan" by Lee Perry-Smith / Infinite Realities,
licensed under Creative Commons Attribution 3.0 (CC BY 3.0,
https://creativecommons.org/licenses/by/3.0/), based on a work at triplegangers.com; OBJ
packaging by Morgan McGuire and Guedis Cardenas (McGuire Graphics Data). Changes: the
vertices welded along the UV seams, the quads split into triangles, rescaled from metres to
millimetres, rotated and moved into the built-in frame, the lips moved apart where the scan's
closed mouth has them passing through each other (:mod:`wrinkle_vis.datasets.lips`), the
lower eyelids' margins and an ear smoothed where they pass through themselves and the flat
folds at the corners of the eyes and the mouth opened a little
(:mod:`wrinkle_vis.datasets.eyelids`), and a skull and muscles added. See the package's
``NOTICE.txt`` file.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from wrinkle_vis.core import FaceModel, Layout, TriangleSurface, load_layout

__all__ = ["CREDIT", "DATA", "LAYOUT", "lee_perry_smith_uvs", "load_lee_perry_smith"]

#: The derived meshes shipped in the package.
DATA = Path(__file__).with_name("lee_perry_smith.npz")
#: Its muscle layout (millimetres, ``"face": "lee_perry_smith"``).
LAYOUT = Path(__file__).with_name("lee_perry_smith.json")
#: The credit line the licence asks for.
CREDIT = ("Lee Perry-Smith head scan by Lee Perry-Smith / Infinite Realities "
          "(triplegangers.com), CC BY 3.0")


@lru_cache(maxsize=1)
def _arrays() -> dict:
    with np.load(DATA) as data:
        return {k: data[k] for k in data.files}


def _surfaces() -> tuple[TriangleSurface, TriangleSurface]:
    a = _arrays()
    skin = TriangleSurface(a["skin_points"].astype(float), a["skin_triangles"].astype(np.intp))
    skull = TriangleSurface(a["skull_points"].astype(float),
                            a["skull_triangles"].astype(np.intp))
    return skin, skull


def lee_perry_smith_uvs() -> np.ndarray:
    """``(m, 3, 2)``: the UV coordinates of every corner of the head's skin triangles (a
    vertex on a UV seam has one per side), for :func:`~wrinkle_vis.plotting.bake.bake_maps`.
    """
    a = _arrays()
    return a["uv_table"].astype(float)[a["uv_index"].astype(np.intp)]


def load_lee_perry_smith(layout: Layout | None = None,
                         skull: TriangleSurface | None = None) -> FaceModel:
    """The Lee Perry-Smith head as a :class:`~wrinkle_vis.core.face.FaceModel` (mm).

    Parameters
    ----------
    layout : Layout, optional
        Muscles and expressions for the head; default its own (:data:`LAYOUT`).
    skull : TriangleSurface, optional
        Another skull; default the shipped closed one.
    """
    skin, own_skull = _surfaces()
    lay = load_layout(LAYOUT) if layout is None else layout
    return FaceModel(skin, own_skull if skull is None else skull, lay.muscles,
                     lay.expressions, name=lay.name, landmarks=lay.landmarks,
                     unit=lay.unit or "mm", mapping=lay.mapping)
