"""The core's plotting methods, bound onto its classes from outside the core.

:meth:`FaceModel.plot <wrinkle_vis.core.face.FaceModel.plot>`,
:meth:`FaceState.plot <wrinkle_vis.core.face.FaceState.plot>` and
:meth:`FaceState.to_polydata <wrinkle_vis.core.face.FaceState.to_polydata>` need PyVista,
which the core (numpy and scipy only) must not import. As pyvista keeps its ``_plot.py`` at
the top of the package, outside ``pyvista.core``, these live here, above the layers: they
import :mod:`wrinkle_vis.plotting` when called, and ``import wrinkle_vis`` (which every
import of the core runs first) binds them to the core's classes. The core imports no
plotting, not even inside a function.
"""

from __future__ import annotations

from .core.face import FaceModel, FaceState

__all__ = ["plot_face", "plot_state", "to_polydata"]


def plot_face(self: FaceModel, expression="surprise", field: str | None = "W",
              muscle: str | None = None, *, intensity: float = 1.0, refine: bool = False,
              **kwargs):
    """Evaluate ``expression`` (as :meth:`evaluate`) and show its skin coloured by
    ``field`` (see :meth:`FaceState.plot`).

    :func:`wrinkle_vis.plotting.plot_face` (which documents ``kwargs``); needs PyVista,
    imported when called.
    """
    from wrinkle_vis.plotting import plot_face as plot

    return plot(self, expression, field, muscle, intensity=intensity, refine=refine, **kwargs)


def plot_state(self: FaceState, field: str | None = "W", muscle: str | None = None,
               **kwargs):
    """Show the skin coloured by ``field`` (of ``muscle``, or the total W; None for plain
    skin): in a notebook with PyVista's trame backend when it is installed, else as an
    image; elsewhere in a window, or off screen without a display.

    :func:`wrinkle_vis.plotting.plot_state` (which documents ``kwargs``); needs PyVista,
    imported when called.
    """
    from wrinkle_vis.plotting import plot_state as plot

    return plot(self, field, muscle, **kwargs)


def to_polydata(self: FaceState):
    """The skin as ``pyvista.PolyData`` with every field as a named point array.

    :func:`wrinkle_vis.plotting.to_polydata`; needs PyVista, imported when called.
    """
    from wrinkle_vis.plotting import to_polydata as polydata

    return polydata(self)


def _bind(cls: type, name: str, function) -> None:
    """``cls.name = function``, named as a method of ``cls`` (for ``help`` and the docs)."""
    function.__name__, function.__qualname__ = name, f"{cls.__name__}.{name}"
    setattr(cls, name, function)


_bind(FaceModel, "plot", plot_face)
_bind(FaceState, "plot", plot_state)
_bind(FaceState, "to_polydata", to_polydata)
