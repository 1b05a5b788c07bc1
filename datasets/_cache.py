"""The on-disk cache of built surfaces: ``$WRINKLE_VIS_CACHE``, else
``$XDG_CACHE_HOME/wrinkle-vis`` (``~/.cache/wrinkle-vis``).

An entry is an ``.npz`` of arrays under a key of the code that builds it and of the
arguments, so a change to that code builds it anew. Writes are atomic; a damaged entry is
built again; a cache that cannot be written (a read-only home) only makes a build slower.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from wrinkle_vis.core.files import atomic_write_bytes

__all__ = ["cache_dir", "cache_key", "cached", "surface_arrays"]

#: The modules whose code shapes what is cached (the built-in face's fields and meshing, the
#: level-set sampling, the landmark fit): a change to one rebuilds every entry.
SOURCES = tuple(Path(__file__).with_name(name)
                for name in ("anatomy.py", "sdf.py", "face.py", "landmarks.py"))


def cache_dir() -> Path:
    """The cache's folder (see the module docstring); read from the environment each call."""
    root = os.environ.get("WRINKLE_VIS_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "wrinkle-vis")
    return Path(root)


def cache_key(*parts) -> str:
    """20 hex digits: a SHA-256 of :data:`SOURCES` and ``repr(parts)``."""
    h = hashlib.sha256()
    for src in SOURCES:
        h.update(src.read_bytes())
    h.update(repr(parts).encode())
    return h.hexdigest()[:20]


def surface_arrays(arrays: dict) -> dict:
    """``arrays`` if it holds a triangle surface: ``points`` ``(n, 3)`` finite floats and
    ``triangles`` ``(m, 3)`` integers in ``[0, n)``, ``n, m > 0``; else ``ValueError``.
    """
    points, triangles = arrays["points"], arrays["triangles"]
    if points.ndim != 2 or points.shape[1] != 3 or not len(points) or \
            points.dtype.kind != "f" or not np.isfinite(points).all():
        raise ValueError(f"points of shape {points.shape} ({points.dtype})")
    if triangles.ndim != 2 or triangles.shape[1] != 3 or not len(triangles) or \
            triangles.dtype.kind not in "iu" or triangles.min() < 0 or \
            triangles.max() >= len(points):
        raise ValueError(f"triangles of shape {triangles.shape} ({triangles.dtype})")
    return arrays


def cached(name: str, parts: tuple, build: Callable[[], dict],
           check: Callable[[dict], dict] = surface_arrays) -> dict:
    """``build()`` -> dict of arrays, cached on disk under a key of the code and ``parts``.

    An entry that does not load (truncated, empty, not a zip) or that ``check`` refuses (a
    member missing, a wrong shape or type, indices out of range) is rebuilt and written
    again.
    """
    path = cache_dir() / f"{name}-{cache_key(name, *parts)}.npz"
    if path.exists():
        try:
            with open(path, "rb") as fh, np.load(fh) as data:  # closed if np.load fails
                return check({k: data[k] for k in data.files})
        except Exception:  # BadZipFile, EOFError, KeyError, zlib.error, ValueError, ...
            pass  # a damaged cache entry is rebuilt
    arrays = build()
    try:  # synced before the rename; on a failure (a full disk) no temporary stays
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, lambda fh: np.savez(fh, **arrays))
    except (OSError, ValueError):
        pass  # a read-only home still gets a face, only slower
    return arrays
