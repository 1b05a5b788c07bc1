"""Off-screen rendering without a display, and whether there is a display (no Qt).

On Linux VTK opens an X window for off-screen rendering too when it can (its default
render window is ``vtkXOpenGLRenderWindow``). With no X server it prints
``vtkXOpenGLRenderWindow: bad X server connection. DISPLAY=...`` and only then falls back to
EGL. :func:`headless_rendering` asks for EGL from the start when no X display can be
opened, so a headless run prints nothing. :func:`display_available` tells the app whether a
window can be shown at all.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["display_available", "headless_rendering", "prefer_egl_when_headless",
           "x_display_reachable"]

#: The environment variable VTK (9.4 and later) reads to pick its OpenGL render window.
VTK_WINDOW_VARIABLE = "VTK_DEFAULT_OPENGL_WINDOW"


def _quietly(call, *args):
    """``call(*args)`` with the process's standard error (file descriptor 2) silenced, so a
    C library's own messages (Xlib's "Authorization required, ...") do not reach the user.
    """
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
            return call(*args)
    finally:
        os.dup2(saved, 2)
        os.close(saved)


@functools.lru_cache(maxsize=8)
def _x_reachable(display: str) -> bool:
    name = ctypes.util.find_library("X11") or "libX11.so.6"
    try:
        xlib = ctypes.CDLL(name)
    except OSError:
        return False
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    handle = _quietly(xlib.XOpenDisplay, display.encode())  # Xlib prints its refusals
    if not handle:
        return False
    xlib.XCloseDisplay(handle)
    return True


def x_display_reachable(display: str | None = None) -> bool:
    """Whether an X display (default ``$DISPLAY``) can be opened (False without one)."""
    display = os.environ.get("DISPLAY", "") if display is None else display
    return bool(display) and _x_reachable(display)


def _wayland_reachable() -> bool:
    name = os.environ.get("WAYLAND_DISPLAY", "")
    if not name:
        return False
    path = name if os.path.isabs(name) else os.path.join(
        os.environ.get("XDG_RUNTIME_DIR", ""), name)
    return os.path.exists(path)


def display_available() -> bool:
    """Whether a window can be shown: always on macOS and Windows; on Linux an X display
    that opens or a Wayland socket that exists (or ``QT_QPA_PLATFORM`` set by the user).
    """
    if sys.platform in ("darwin", "win32") or os.environ.get("QT_QPA_PLATFORM"):
        return True
    return x_display_reachable() or _wayland_reachable()


def _egl_available() -> bool:
    try:
        ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
    except OSError:
        return False
    return True


@contextmanager
def headless_rendering() -> Iterator[str | None]:
    """Within the block, render off screen through EGL when no X display opens (Linux).

    Sets ``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` (restored on leaving) unless the
    user set it, so VTK does not try X first and print "bad X server connection". Render
    windows made in the block use it. Yields the render window chosen, or None when nothing
    changed (a reachable display, another platform, no EGL library, the user's own choice).
    """
    chosen = None
    if (sys.platform.startswith("linux") and not os.environ.get(VTK_WINDOW_VARIABLE)
            and not x_display_reachable() and _egl_available()):
        chosen = "vtkEGLRenderWindow"
        os.environ[VTK_WINDOW_VARIABLE] = chosen
    try:
        yield chosen
    finally:
        if chosen is not None:
            os.environ.pop(VTK_WINDOW_VARIABLE, None)


def prefer_egl_when_headless() -> str | None:
    """For the whole process: when no X display opens (Linux) and the user chose no render
    window, ask VTK for EGL, so off-screen rendering from the library (``render_field``,
    figures, notebooks) prints no "bad X server connection" either. Returns the window
    chosen, or None when nothing changed. :mod:`wrinkle_vis.plotting` calls it on import.
    """
    if (sys.platform.startswith("linux") and not os.environ.get(VTK_WINDOW_VARIABLE)
            and not x_display_reachable() and _egl_available()):
        os.environ[VTK_WINDOW_VARIABLE] = "vtkEGLRenderWindow"
        return "vtkEGLRenderWindow"
    return None
