"""One check every writer calls before it writes: nothing non-finite is written as valid.

A frame whose parameters overflow (a furrow depth factor of 1e300) has NaN normals and
points beyond any float32 reader; written, it reads as a valid mesh, image or texture.
:func:`require_finite` refuses it in one line, before the writer touches the target.
NaN is the model's "undefined" in the per-muscle fields (outside a muscle's area of
influence), so it is allowed there; the positions, the normals and the totals
(:data:`ALWAYS_DEFINED`) must be finite, and no array may hold an infinity.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

from ..core.files import WriteError

__all__ = ["ALWAYS_DEFINED", "NonFiniteError", "require_finite"]

#: Point arrays the model defines everywhere (:func:`~wrinkle_vis.plotting.to_polydata`):
#: NaN in them is a failure, not "undefined".
ALWAYS_DEFINED = ("W", "deformation", "rest_points", "Normals", "normals")


class NonFiniteError(WriteError):
    """Data to be written holds NaN or inf where a number belongs; nothing was written."""


def require_finite(target: str | os.PathLike | None, data) -> None:
    """Refuse to write ``data`` to ``target`` if it holds non-finite numbers.

    Parameters
    ----------
    target : path or str or None
        What would be written (named in the message).
    data : FaceState, pyvista.DataSet, pyvista.MultiBlock, mapping of str to array, or array
        A state: its points, normals and ``W`` must be finite. A dataset: its points, and
        the point arrays of :data:`ALWAYS_DEFINED`; any other float array may hold NaN (the
        model's "undefined") but no inf. A mapping or an array: every value finite.

    Raises
    ------
    NonFiniteError
        One line naming the target, the array, how many values and the way out.
    """
    for name, values, nan_ok in _arrays(data):
        values = np.asarray(values)
        if values.dtype.kind not in "fc":
            continue
        bad = np.isinf(values) if nan_ok else ~np.isfinite(values)
        if bad.any():
            where = f"{str(target)!r}" if target is not None else "the output"
            raise NonFiniteError(
                f"refusing to write {where}: {int(bad.sum()):,} non-finite value(s) (NaN or "
                f"inf) in {name}; the model overflowed, so check the muscles' k0, strength "
                "and lengths against the face's size; nothing was written")


def _arrays(data, prefix: str = ""):
    """``(name, values, nan_allowed)`` for every array of ``data`` to check."""
    if isinstance(data, np.ndarray):
        yield prefix or "the data", data, False
    elif isinstance(data, Mapping):
        for key, value in data.items():
            yield f"{prefix}{key}", value, False
    elif hasattr(data, "point_data"):  # a pyvista dataset
        yield f"{prefix}the points", np.asarray(data.points), False
        for key in data.point_data:
            yield f"{prefix}the point array {key!r}", data.point_data[key], \
                key not in ALWAYS_DEFINED
    elif hasattr(data, "normals") and hasattr(data, "W"):  # a FaceState
        yield f"{prefix}the points", data.points, False
        yield f"{prefix}the normals", data.normals, False
        yield f"{prefix}W", data.W, False
    else:  # a MultiBlock, or any other sequence of the above
        for i, block in enumerate(data):
            if block is not None:
                yield from _arrays(block, f"{prefix}block {i}: ")
