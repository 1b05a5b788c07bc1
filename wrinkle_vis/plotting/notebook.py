"""The skin and its fields in Jupyter: ``state.plot(...)``, ``face.plot(...)`` and a widget.

:func:`plot_state` (behind :meth:`FaceState.plot <wrinkle_vis.core.face.FaceState.plot>`
and :meth:`FaceModel.plot <wrinkle_vis.core.face.FaceModel.plot>`) draws the final skin
coloured by a field. In a notebook it is shown with PyVista's ``trame`` backend when
``trame``, ``trame-vtk``, ``trame-vuetify`` and ``trame-pyvista`` are installed
(interactive: rotate, zoom), else as a static image; :func:`default_backend` says which:
``pyvista.set_jupyter_backend(...)`` (or ``$PYVISTA_JUPYTER_BACKEND``) chooses, as for
PyVista's own plots, and ``$WRINKLE_VIS_JUPYTER_BACKEND`` (``trame``, ``static``, ...)
chooses for wrinkle-vis alone. An interactive view is output with a PNG of it beside, so a
notebook shown statically (nbconvert's HTML, GitHub) still has its figures. Outside a
notebook the plotter opens a window, or renders off screen where there is no display.

As with ``pyvista.plot``, keyword arguments of ``Plotter.show`` (``screenshot``,
``return_viewer``, ``jupyter_kwargs``, ...) go to ``show`` and the others to ``add_mesh``
(``cmap``, ``opacity``, ``scalar_bar_args``, ...).

:class:`FaceExplorer` is an ipywidgets panel (expression, intensity, field, muscle,
refine) over one view that it updates in place: a new frame is written into the drawn
mesh's points and scalars, and only a new field or muscle draws the skin again.
"""

from __future__ import annotations

import base64
import importlib.util
import inspect
import io
import os

import numpy as np
import pyvista as pv
import scooby

from ..core.face import FaceModel, FaceState
from .fields import FIELDS, field_info, field_range
from .offscreen import display_available, headless_rendering
from .polydata import field_array_name, to_surface_polydata
from .scenes import add_raking_light, add_skin, clear_scene, replace_mesh, set_camera

__all__ = ["BACKEND_VARIABLE", "SHOW_OPTIONS", "TRAME_PACKAGES", "FaceExplorer", "default_backend",
           "has_display", "in_notebook", "notebook_plotter", "plot_face", "plot_state"]

#: The import names of the packages PyVista's ``trame`` backend needs here.
TRAME_PACKAGES = ("trame", "trame_vtk", "trame_vuetify", "trame_pyvista", "nest_asyncio2",
                  "ipywidgets")
#: The environment variable that chooses the notebook backend.
BACKEND_VARIABLE = "WRINKLE_VIS_JUPYTER_BACKEND"
#: The default view size in pixels (width, height).
WINDOW_SIZE = (640, 560)
#: The colour of the triangles' edges (``show_edges``): darker than the skin, not black.
EDGE_COLOR = "#a0826d"


#: The keyword arguments of ``pyvista.Plotter.show`` (the others go to ``add_mesh``).
SHOW_OPTIONS = frozenset(inspect.signature(pv.Plotter.show).parameters) - {
    "self", "kwargs", "window_size", "title"} | {"jupyter_kwargs"}


def default_backend() -> str:
    """The notebook backend :func:`plot_state` uses: PyVista's, when set
    (``pyvista.set_jupyter_backend(...)`` or ``$PYVISTA_JUPYTER_BACKEND``: the theme's
    ``jupyter_backend``), else ``$WRINKLE_VIS_JUPYTER_BACKEND`` if set, else ``"trame"``
    when every package of :data:`TRAME_PACKAGES` is installed, else ``"static"``.
    """
    chosen = str(pv.global_theme.jupyter_backend or "").strip().lower()
    chosen = chosen or os.environ.get(BACKEND_VARIABLE, "").strip().lower()
    if chosen:
        return chosen
    if all(importlib.util.find_spec(name) is not None for name in TRAME_PACKAGES):
        return "trame"
    return "static"


def in_notebook() -> bool:
    """Whether this Python runs in a Jupyter kernel (as PyVista decides it)."""
    return scooby.in_ipykernel()


def has_display() -> bool:
    """Whether a native window can open (:func:`~wrinkle_vis.plotting.offscreen.display_available`:
    always on Windows and macOS; on Linux an X display that opens or a Wayland socket).
    """
    return display_available()


def notebook_plotter(window_size=WINDOW_SIZE, *, off_screen: bool | None = None,
                     **kwargs) -> pv.Plotter:
    """A ``pyvista.Plotter`` that is safe here: off screen in a notebook and where there is
    no display (``off_screen`` forces either way), through EGL when no X display opens;
    ``kwargs`` go to the plotter.
    """
    notebook = in_notebook()
    if off_screen is None:
        off_screen = notebook or pv.OFF_SCREEN or not has_display()
    with headless_rendering():
        return pv.Plotter(off_screen=off_screen, notebook=notebook,
                          window_size=list(window_size), **kwargs)


def _draw(plotter: pv.Plotter, state: FaceState, field, muscle, *, camera, raking_light,
          show_edges: bool, clim, title, **mesh_kwargs):
    """Draw ``state``'s skin (replacing the plotter's scene; ``mesh_kwargs`` go to
    ``add_mesh``); returns the skin actor.
    """
    if field is None and muscle is not None:
        raise ValueError("plain skin (field=None) shows no muscle's field; give a field")
    clear_scene(plotter)
    actor = add_skin(plotter, state, field, muscle, show_edges=show_edges,
                     edge_color=EDGE_COLOR if show_edges else None, **mesh_kwargs)
    if field is not None and clim is not None:
        actor.mapper.scalar_range = tuple(clim)
    if (field is None) if raking_light is None else raking_light:
        add_raking_light(plotter)
    if title:
        plotter.add_text(str(title), position="upper_left", font_size=10, name="title",
                         render=False)
    if camera is not None:
        set_camera(plotter, camera, state.face)
    return actor


def plot_state(state: FaceState, field: str | None = "W", muscle: str | None = None, *,
               jupyter_backend: str | None = None, camera: str | None = "front",
               window_size=WINDOW_SIZE, raking_light: bool | None = None,
               show_edges: bool = False, clim=None, title: str | None = None,
               off_screen: bool | None = None, return_plotter: bool = False, **kwargs):
    """Show the final skin of ``state`` coloured by ``field``.

    Parameters
    ----------
    state : FaceState
        The frame.
    field : str or None, default "W"
        A field of :data:`~wrinkle_vis.plotting.FIELDS`; None for plain skin (under a
        raking light, so that the wrinkles show as relief).
    muscle : str, optional
        Whose field; None for the total (``W`` only).
    jupyter_backend : str, optional
        In a notebook: ``"trame"`` (interactive), ``"static"`` (an image) or any backend
        PyVista knows; default :func:`default_backend`. Ignored outside a notebook.
    camera : str or None, default "front"
        A camera of :data:`~wrinkle_vis.plotting.CAMERAS`; None leaves PyVista's.
    window_size : (int, int)
        The view's size in pixels.
    raking_light : bool, optional
        Light the skin with :func:`~wrinkle_vis.plotting.add_raking_light`; default: for
        plain skin only.
    show_edges : bool, default False
        Draw the triangles' edges (to see a refinement).
    clim : (float, float), optional
        The colour range; default the field's own (:func:`field_range`).
    title : str, optional
        Text in the upper left corner.
    off_screen : bool, optional
        Render off screen; default: in a notebook and where there is no display.
    return_plotter : bool, default False
        Return the plotter with the scene drawn, not shown (add to it, then ``show()``,
        which takes the options of ``show``: giving them here is an error).
    **kwargs
        As for ``pyvista.plot``: the keyword arguments of ``pyvista.Plotter.show``
        (:data:`SHOW_OPTIONS`: ``screenshot="skin.png"``, ``return_viewer=True`` for the
        notebook widget, ``jupyter_kwargs``, ...) go to ``show``, the others to
        ``add_mesh`` (``cmap="magma"``, ``opacity``, ``scalar_bar_args``, ...).

    Returns
    -------
    object
        The plotter with ``return_plotter``, else what ``Plotter.show`` returns (None in
        a notebook, where the view is displayed, unless ``return_viewer`` is given). A
        static image in a notebook closes its plotter once shown; an interactive view is
        displayed with a PNG of it for frontends that cannot run it.

    Raises
    ------
    TypeError
        For an option of ``show`` with ``return_plotter=True``, or one ``add_mesh`` does
        not take.
    """
    if not isinstance(state, FaceState):
        raise TypeError(f"state must be a FaceState; got {type(state).__name__}")
    show_kwargs = {k: v for k, v in kwargs.items() if k in SHOW_OPTIONS}
    mesh_kwargs = {k: v for k, v in kwargs.items() if k not in SHOW_OPTIONS}
    if return_plotter and show_kwargs:
        raise TypeError(f"{', '.join(sorted(show_kwargs))}: options of Plotter.show(); with "
                        "return_plotter=True give them to the returned plotter's show()")
    plotter = notebook_plotter(window_size, off_screen=off_screen)
    try:
        _draw(plotter, state, field, muscle, camera=camera, raking_light=raking_light,
              show_edges=show_edges, clim=clim, title=title, **mesh_kwargs)
    except BaseException:
        plotter.close()
        raise
    return plotter if return_plotter else _shown(plotter, show_kwargs, jupyter_backend)


def _shown(plotter, show_kwargs: dict, jupyter_backend: str | None):
    """Show ``plotter`` (see :func:`plot_state`): in a window, or in a notebook with
    ``jupyter_backend`` (default :func:`default_backend`); returns what ``show`` does.
    """
    if not plotter.notebook:
        return plotter.show(**show_kwargs)
    backend = show_kwargs.setdefault("jupyter_backend", jupyter_backend or default_backend())
    if backend == "none" or show_kwargs.get("return_viewer"):
        return plotter.show(**show_kwargs)  # the view lives on: PyVista keeps the plotter
    if backend != "static":
        return _show_with_image(plotter, show_kwargs)
    try:  # the image is shown: free the render window (PyVista keeps notebook plotters)
        return plotter.show(**show_kwargs)
    finally:
        plotter.close()


class _ViewWithImage:
    """A notebook view and a PNG of it in one output: frontends that run widgets show the
    view, the others (nbconvert's HTML without widget state, GitHub) the image.
    """

    def __init__(self, view, png: bytes):
        self.view, self.png = view, png

    def _repr_mimebundle_(self, include=None, exclude=None):
        view = self.view
        if hasattr(view, "_repr_mimebundle_"):
            bundle = dict(view._repr_mimebundle_(include=include, exclude=exclude) or {})
        else:
            bundle = {"text/plain": repr(view)}
            if hasattr(view, "_repr_html_"):
                bundle["text/html"] = view._repr_html_()
        bundle["image/png"] = base64.b64encode(self.png).decode("ascii")
        return bundle


def _show_with_image(plotter: pv.Plotter, show_kwargs: dict) -> None:
    """Display ``plotter``'s interactive notebook view with a PNG of it (the scene as
    drawn, before any interaction).
    """
    import IPython.display

    plotter.render()
    png = _png(plotter.screenshot(return_img=True))
    view = plotter.show(**show_kwargs, return_viewer=True)
    IPython.display.display(_ViewWithImage(view, png))


def plot_face(face: FaceModel, expression="surprise", field: str | None = "W",
              muscle: str | None = None, *, intensity: float = 1.0, refine: bool = False,
              **kwargs):
    """Evaluate ``expression`` (see :meth:`FaceModel.evaluate`) and :func:`plot_state` it,
    titled with the expression's name; ``kwargs`` go to :func:`plot_state`.
    """
    state = face.evaluate(expression, intensity, refine=refine)
    if isinstance(expression, str):
        kwargs.setdefault("title", f"{expression} {intensity:.0%}"
                          + (", refined" if refine else ""))
    return plot_state(state, field, muscle, **kwargs)


def _png(image: np.ndarray) -> bytes:
    """PNG bytes of an ``(h, w, 3)`` uint8 image."""
    import imageio.v3 as iio

    buffer = io.BytesIO()
    iio.imwrite(buffer, np.ascontiguousarray(image), extension=".png")
    return buffer.getvalue()


def _field_options() -> list[tuple[str, str | None]]:
    return [("none (plain skin)", None)] + [(f"{key}: {info.name}", key)
                                            for key, info in FIELDS.items()]


class FaceExplorer:
    """A notebook panel: expression, intensity, field, muscle and refine over one view.

    The view is PyVista's ``trame`` viewer (interactive) or an image (``static``), see
    :func:`default_backend`. A change of expression, intensity or refinement writes the
    new frame into the drawn mesh (points and the field's values, the colour range; a
    refined skin of other triangles replaces the mesh under the same actor); a change of
    field or muscle draws the skin again. The camera stays where the user put it.

    Parameters
    ----------
    face : FaceModel
        The face.
    expression : str, default "surprise"
        The expression first shown (one of ``face.expressions``).
    field : str or None, default "W"
        The field first shown; None for plain skin.
    muscle : str, optional
        Whose field; None for the total W. A per-muscle field with no muscle takes the
        first muscle the expression contracts.
    intensity : float, default 1.0
        In ``[0, 1]``.
    refine : bool, default False
        Refine adaptively where the skin bends (:meth:`FaceModel.evaluate`).
    backend : str, optional
        ``"trame"`` or ``"static"``; default :func:`default_backend` (anything other than
        ``"trame"`` shows an image).
    camera : str, default "front"
        The first camera (:data:`~wrinkle_vis.plotting.CAMERAS`).
    window_size : (int, int)
        The view's size in pixels.

    Attributes
    ----------
    widget : ipywidgets.VBox
        The panel: the controls above the view.
    controls : dict of str to ipywidgets.Widget
        ``expression``, ``intensity``, ``field``, ``muscle`` and ``refine``.
    plotter : pyvista.Plotter
        The off-screen plotter behind the view.
    state : FaceState
        The frame shown.
    n_rebuilds, n_updates : int
        How many times the skin was drawn anew and updated in place.

    Examples
    --------
    >>> explorer = FaceExplorer(wv.datasets.load_face())  # doctest: +SKIP
    >>> explorer  # the last line of a cell shows the panel  # doctest: +SKIP
    >>> explorer.set(expression="frown", field="gamma", muscle="corrugator_L")  # doctest: +SKIP
    """

    def __init__(self, face: FaceModel, expression: str = "surprise", field: str | None = "W",
                 muscle: str | None = None, intensity: float = 1.0, refine: bool = False, *,
                 backend: str | None = None, camera: str = "front",
                 window_size=WINDOW_SIZE):
        import ipywidgets as widgets

        if field is not None:
            field_info(field)  # raises, listing the fields
        if muscle is not None:
            face.muscle(muscle)  # raises, listing the muscles
        self.face = face
        self.backend = backend or default_backend()
        self.camera = camera
        self.n_rebuilds = self.n_updates = 0
        self._key = None
        self._skin = None  # the skin (triangles) the drawn mesh has
        self._syncing = False
        layout = widgets.Layout(width="auto")
        style = {"description_width": "initial"}
        self.controls = {
            "expression": widgets.Dropdown(options=list(face.expressions), value=expression,
                                           description="Expression", style=style),
            "intensity": widgets.FloatSlider(value=intensity, min=0.0, max=1.0, step=0.05,
                                             description="Intensity", readout_format=".0%",
                                             continuous_update=False, style=style),
            "field": widgets.Dropdown(options=_field_options(), value=field,
                                      description="Field", style=style),
            "muscle": widgets.Dropdown(options=[("total", None)]
                                       + [(n, n) for n in face.muscle_names], value=muscle,
                                       description="Muscle", style=style),
            "refine": widgets.Checkbox(value=bool(refine), description="Refine adaptively",
                                       indent=False, layout=layout),
        }
        self.plotter = notebook_plotter(window_size, off_screen=True)
        self.state = None
        self._fix_muscle()
        self._show_frame()
        if self.backend == "trame" and not self.plotter.notebook:
            self.backend = "static"  # PyVista serves trame views to notebooks only
        if self.backend == "trame":
            self.view = self.plotter.show(jupyter_backend="trame", return_viewer=True,
                                          auto_close=False)
        else:
            self.view = widgets.Image(value=self._screenshot(), format="png",
                                      layout=widgets.Layout(width=f"{window_size[0]}px"))
        for control in self.controls.values():
            control.observe(self._on_change, names="value")
        c = self.controls
        self.widget = widgets.VBox([
            widgets.HBox([c["expression"], c["intensity"], c["refine"]]),
            widgets.HBox([c["field"], c["muscle"]]),
            self.view,
        ])

    # ------------------------------------------------------------------ public
    @property
    def values(self) -> dict:
        """The controls' values: expression, intensity, field, muscle, refine."""
        return {name: control.value for name, control in self.controls.items()}

    @property
    def mesh(self) -> pv.PolyData:
        """The mesh the view draws."""
        return self.plotter.actors["skin"].mapper.dataset

    def set(self, **values) -> None:
        """Set controls (as a user would) and update the view once.

        Keyword names are those of :attr:`controls`.
        """
        unknown = sorted(set(values) - set(self.controls))
        if unknown:
            raise KeyError(f"unknown control(s) {', '.join(unknown)}; controls: "
                           f"{', '.join(self.controls)}")
        self._syncing = True
        try:
            for name, value in values.items():
                self.controls[name].value = value
        finally:
            self._syncing = False
        self._fix_muscle()
        self.refresh()

    def refresh(self) -> None:
        """Evaluate the controls' frame and show it (in place where possible)."""
        self._show_frame()
        if self.backend == "trame":
            self.view.viewer.update()
        else:
            self.view.value = self._screenshot()

    def image(self) -> np.ndarray:
        """``(h, w, 3)`` uint8: the view now, rendered off screen."""
        self.plotter.render()  # screenshot() itself renders only the first image
        return self.plotter.screenshot(return_img=True)

    def close(self) -> None:
        """Close the plotter and the widgets."""
        self.plotter.close()
        for widget in (*self.controls.values(), self.view, *self.widget.children,
                       self.widget):
            widget.close()

    def _repr_mimebundle_(self, **kwargs):
        """The panel, with a PNG of the view for frontends that cannot show widgets."""
        bundle = self.widget._repr_mimebundle_(**kwargs)
        bundle["image/png"] = base64.b64encode(_png(self.image())).decode("ascii")
        return bundle

    # ------------------------------------------------------------------ drawing
    def _on_change(self, change) -> None:
        if self._syncing:
            return
        self._syncing = True
        try:
            self._fix_muscle()
        finally:
            self._syncing = False
        self.refresh()

    def _fix_muscle(self) -> None:
        """A per-muscle field needs a muscle: take the first the expression contracts."""
        v = self.values
        if v["field"] is not None and not field_info(v["field"]).total and v["muscle"] is None:
            acts = self.face.activations_for(v["expression"])
            active = [m for m, a in acts.items() if a > 0] or list(self.face.muscle_names)
            self.controls["muscle"].value = active[0]

    def _screenshot(self) -> bytes:
        return _png(self.image())

    def _show_frame(self) -> None:
        v = self.values
        self.state = state = self.face.evaluate(v["expression"], v["intensity"],
                                                refine=v["refine"])
        field, muscle = v["field"], v["muscle"] if v["field"] is not None else None
        key = (field, muscle)
        if key != self._key:  # a new field or muscle: draw the skin anew
            camera = self.plotter.camera_position if self._key is not None else None
            _draw(self.plotter, state, field, muscle, camera=self.camera if camera is None
                  else None, raking_light=None, show_edges=False, clim=None, title=None)
            if camera is not None:
                self.plotter.camera_position = camera
            self._key, self._skin = key, state.face.skin
            self.n_rebuilds += 1
            return
        values = None if field is None else np.asarray(
            state.W if muscle is None else state.fields[muscle][field])
        array = None if field is None else field_array_name(field, muscle)
        if state.face.skin is not self._skin:  # other triangles (refinement): a new mesh
            mesh = to_surface_polydata(state.face.skin, state.points)
            if array is not None:
                mesh.point_data[array] = values
                mesh.set_active_scalars(array)
            replace_mesh(self.plotter, "skin", mesh)
            self._skin = state.face.skin
        else:
            _write(self.mesh, state.points, array, values)
        if array is not None:
            self.plotter.actors["skin"].mapper.scalar_range = field_range(field_info(field),
                                                                          values)
        self.n_updates += 1


def _write(mesh: pv.PolyData, points, array: str | None = None, values=None) -> None:
    """Write a frame into a mesh's own VTK buffers and mark them modified."""
    mesh.points[:] = points
    mesh.GetPoints().Modified()
    if array is not None:
        mesh.point_data[array][:] = values
        mesh.GetPointData().GetArray(array).Modified()
    mesh.Modified()
