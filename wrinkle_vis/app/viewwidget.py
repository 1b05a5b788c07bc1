"""The widget each view of the window draws in: a PyVista plotter inside a Qt widget.

Two kinds, one interface (PyVista's plotter, ``interactor``, ``iren`` and
:meth:`render_now`):

* :class:`NativeView`, the default where Qt runs on X11 (``xcb``), Windows or macOS: VTK's
  own ``QVTKRenderWindowInteractor`` on a plain ``QWidget`` with a native window, into
  which VTK renders directly. Qt composes nothing: a frame costs the renders alone.
* :class:`View`, pyvistaqt's ``QtInteractor`` (a ``QOpenGLWidget``). VTK renders into the
  widget's framebuffer object and Qt composes the whole top-level window with OpenGL
  whenever one of them repaints: in software rendering (Mesa llvmpipe under Xvfb) about
  10 ms a frame of timeline playback in the 1500x800 window
  (``benchmarks/bench_app_playback.py``). It is used where a native window cannot take
  VTK's rendering (Wayland, Qt's offscreen platform) and when the environment variable
  ``WRINKLE_VIS_VIEW=qopenglwidget`` asks for it.

:func:`make_view` picks one.
"""

from __future__ import annotations

import contextlib
import os

import pyvista
import qtpy
from pyvista.plotting.plotter import BasePlotter
from pyvista.plotting.render_window_interactor import RenderWindowInteractor
from pyvistaqt import QtInteractor
from qtpy import QtGui, QtWidgets

__all__ = ["NativeView", "View", "make_view", "view_kind"]

#: Qt platforms whose native child windows VTK renders into.
NATIVE_PLATFORMS = ("xcb", "windows", "cocoa")


def view_kind() -> str:
    """``"native"`` or ``"qopenglwidget"``: the widget :func:`make_view` builds here (the
    environment variable ``WRINKLE_VIS_VIEW`` overrides the platform's default).
    """
    asked = os.environ.get("WRINKLE_VIS_VIEW", "").strip().lower()
    if asked in ("native", "qopenglwidget"):
        return asked
    if asked:
        raise ValueError(f"WRINKLE_VIS_VIEW={asked!r} is not a view kind; use 'native' or "
                         "'qopenglwidget' (or unset it)")
    platform = QtGui.QGuiApplication.platformName()
    return "native" if platform in NATIVE_PLATFORMS else "qopenglwidget"


def make_view(parent: QtWidgets.QWidget | None = None) -> View | NativeView:
    """A view widget of the kind :func:`view_kind` names, parented to ``parent``."""
    if view_kind() == "native":
        return NativeView(parent)
    return View(parent, auto_update=False)


class View(QtInteractor):
    """A view of the window: a ``QtInteractor`` that renders a frame once.

    pyvistaqt's widget renders the scene again in every paint event, also in the one a
    finished render schedules to show itself, so each frame the app rendered was rendered
    twice (half the frame time of timeline playback in software). :meth:`render_now`
    renders the scene at once (a screenshot right after it is of the new frame) and lets
    the paint event that follows show that render without making another. Any other
    paint (an expose, a resize, the interactor's own renders) renders as before.
    """

    _fresh = False  # rendered by render_now, not shown yet

    def render_now(self) -> None:
        """Render the scene now; the next paint shows this render."""
        self.render_window.Render()  # its frame event schedules the paint
        self._fresh = True

    def resizeGL(self, w, h):  # noqa: N802 (Qt's name)
        """A resize: the next paint renders at the new size."""
        self._fresh = False
        super().resizeGL(w, h)

    def paintGL(self):  # noqa: N802 (Qt's name)
        """Show the render :meth:`render_now` made, or render (any other paint)."""
        fresh, self._fresh = self._fresh, False
        if not fresh or getattr(self, "_in_paint", None) is not False:
            super().paintGL()
            return
        self._in_paint = True  # pyvistaqt's paintGL: "a render is under way", no render
        try:
            super().paintGL()
        finally:
            self._in_paint = False


def _native_base():
    """VTK's ``QVTKRenderWindowInteractor`` on a ``QWidget``, bound to qtpy's Qt."""
    import vtkmodules.qt

    vtkmodules.qt.PyQtImpl = qtpy.API_NAME  # the binding qtpy chose, not VTK's first guess
    vtkmodules.qt.QVTKRWIBase = "QWidget"
    from vtkmodules.qt.QVTKRenderWindowInteractor import QVTKRenderWindowInteractor

    return QVTKRenderWindowInteractor


def _window_for_platform():
    """A render window for a native window of Qt's platform: on X11 an X one, whatever
    VTK's factory would pick (it picks EGL when no display was set as VTK loaded, and an
    EGL window cannot draw into an X window); elsewhere the factory's.
    """
    if QtGui.QGuiApplication.platformName() == "xcb":
        from vtkmodules.vtkRenderingOpenGL2 import vtkXOpenGLRenderWindow

        return vtkXOpenGLRenderWindow()
    from vtkmodules.vtkRenderingCore import vtkRenderWindow

    return vtkRenderWindow()


class _EndOfQtInit:
    """Ends the cooperative ``super().__init__`` chain that Qt's ``QWidget.__init__``
    continues after the Qt classes: placed before ``BasePlotter`` in a view's bases, it
    takes that call (which has none of the plotter's arguments), so the view calls
    ``BasePlotter.__init__`` itself, once, with them. (pyvistaqt swaps
    ``BasePlotter.__init__`` for a no-op while the Qt base initializes instead.)
    """

    def __init__(self, *args, **kwargs):
        pass


class _NoEvents:
    """Stands in for the VTK interactor after close (Qt may still send a leave event)."""

    def __getattr__(self, name):
        return lambda *args, **kwargs: None


_NativeBase = _native_base()


class NativeView(_NativeBase, _EndOfQtInit, BasePlotter):
    """A PyVista plotter in a native child window that VTK renders into directly.

    Mouse and key events reach VTK's interactor as in pyvistaqt (through
    ``QVTKRenderWindowInteractor``); the plotter's interactor (``iren``) has the trackball
    style and PyVista's key bindings. A paint event (an expose, a resize) renders the
    scene; :meth:`render_now` renders it at once, and nothing renders it again.
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None, **kwargs):
        _NativeBase.__init__(self, parent, rw=_window_for_platform())
        BasePlotter.__init__(self, **kwargs)
        self.interactor = self
        self.ren_win = self.GetRenderWindow()
        self.ren_win.SetMultiSamples(pyvista.global_theme.multi_samples)
        self.ren_win.SetAlphaBitPlanes(1)  # an alpha channel: PyVista's depth peeling needs one
        for renderer in self.renderers:
            renderer.view_isometric()
            self.ren_win.AddRenderer(renderer)
        self.background_color = pyvista.global_theme.background
        self._off_screen = False
        self.iren = RenderWindowInteractor(self, interactor=self.ren_win.GetInteractor())
        self.iren.interactor.RemoveObservers("MouseMoveEvent")
        self.iren.initialize()
        self.enable_trackball_style()
        self._observers = {}
        self.iren.add_observer("KeyPressEvent", self.key_press_event)
        self.reset_key_events()
        self._first_time = False  # BasePlotter: a window exists, rendering is safe

    def render_now(self) -> None:
        """Render the scene now (into the window: no paint follows)."""
        if not self._closed:
            self.ren_win.Render()

    def render(self) -> None:
        """Render the scene (PyVista's plotter methods call this), unless closed."""
        if getattr(self, "_closed", True):
            return
        self._rendered = True
        BasePlotter.render(self)

    def paintEvent(self, ev):  # noqa: N802 (Qt's name)
        """An expose: render the scene (not once closed)."""
        if not getattr(self, "_closed", True):
            super().paintEvent(ev)

    def resizeEvent(self, ev):  # noqa: N802 (Qt's name)
        """Size the render window to the widget (not once closed)."""
        if not getattr(self, "_closed", True):
            super().resizeEvent(ev)

    def close(self) -> None:
        """Close the plotter and the widget (returns None, as pyvistaqt's)."""
        if getattr(self, "_closed", True):
            return
        BasePlotter.close(self)
        QtWidgets.QWidget.close(self)
        self._Iren = _NoEvents()
        for key in ("_RenderWindow", "renderer"):
            with contextlib.suppress(AttributeError):
                setattr(self, key, None)

    def closeEvent(self, evt):  # noqa: N802 (Qt's name)
        """Qt closes the widget; the plotter is closed by :meth:`close` (the window's)."""
        evt.accept()
