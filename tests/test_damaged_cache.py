"""A damaged entry of the on-disk face cache is rebuilt, never a traceback (issue 33, H5)."""

import os

import numpy as np
import pytest

from wrinkle_vis.datasets._cache import cached

POINTS = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TRIANGLES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _truncate(path):
    with open(path, "r+b") as fh:
        fh.truncate(os.path.getsize(path) // 2)


def _empty(path):
    path.write_bytes(b"")


def _garbage(path):
    path.write_bytes(b"\x00" * 64)


def _member_missing(path):
    np.savez(path, points=POINTS)


def _wrong_shape(path):
    np.savez(path, points=POINTS[:, :2], triangles=TRIANGLES)


def _index_out_of_range(path):
    np.savez(path, points=POINTS, triangles=TRIANGLES + 7)


def _not_finite(path):
    np.savez(path, points=np.where(POINTS == 1.0, np.nan, POINTS), triangles=TRIANGLES)


def _float_triangles(path):
    np.savez(path, points=POINTS, triangles=TRIANGLES + 0.5)


def _pickled(path):
    np.savez(path, points=np.array([object()], dtype=object), triangles=TRIANGLES)


@pytest.mark.parametrize("damage", [_truncate, _empty, _garbage, _member_missing, _wrong_shape,
                                    _index_out_of_range, _not_finite, _float_triangles,
                                    _pickled])
def test_a_damaged_cache_entry_is_rebuilt_and_written_again(tmp_path, monkeypatch, damage):
    monkeypatch.setenv("WRINKLE_VIS_CACHE", str(tmp_path))
    built = []

    def build():
        built.append(1)
        return {"points": POINTS.copy(), "triangles": TRIANGLES.copy()}

    first = cached("skin", (4,), build)
    (path,) = tmp_path.glob("skin-*.npz")
    assert cached("skin", (4,), build) and len(built) == 1  # a hit
    damage(path)
    again = cached("skin", (4,), build)
    assert len(built) == 2  # rebuilt, no traceback
    for key in ("points", "triangles"):
        np.testing.assert_array_equal(again[key], first[key])
    with np.load(path) as data:  # and written again, whole
        np.testing.assert_array_equal(data["points"], POINTS)
        np.testing.assert_array_equal(data["triangles"], TRIANGLES)
    cached("skin", (4,), build)
    assert len(built) == 2
