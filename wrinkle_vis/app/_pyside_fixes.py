"""Work-arounds for bugs of the Qt bindings (called once, by the main window)."""

from __future__ import annotations

import ctypes
import sys

from qtpy import QtCore

__all__ = ["guard_none_refcount"]


def guard_none_refcount() -> bool:
    """Keep a long session from dying of "Fatal Python error: deallocating None".

    PySide6 6.12 (an abi3 wheel) on Python 3.11 drops a reference to ``None`` at every call
    of a Qt method that returns nothing (``update()``, ``setText()``...): some ten per frame
    of the app, so that after about 9,000 frames of Play ``None``'s count reaches 0 and the
    interpreter aborts (``benchmarks/bench_soak.py`` found it). Python 3.12 made ``None``
    immortal; where a probe shows the drift here, ``None`` gets 2**40 references more,
    once, which no session spends. Returns whether it did.
    """
    global _NONE_GUARDED
    if _NONE_GUARDED or sys.version_info >= (3, 12) or sys.implementation.name != "cpython":
        return False
    probe = QtCore.QObject()
    before = sys.getrefcount(None)
    for _ in range(16):
        probe.setObjectName("probe")  # returns nothing
    if sys.getrefcount(None) >= before:
        return False
    ctypes.c_ssize_t.from_address(id(None)).value += 1 << 40  # ob_refcnt, first field
    _NONE_GUARDED = True
    return True


_NONE_GUARDED = False
