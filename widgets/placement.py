"""Placement widgets: handles that slide on the skin or the skull, and the muscle's AOI drawn.

A widget belongs to one muscle and draws into the app's three views, given as a mapping
``{"skin": plotter, "muscles": plotter, "skull": plotter}`` whose skin and skull views hold
actors named ``"skin"`` and ``"skull"`` (as :func:`wrinkle_vis.plotting.add_skin` and
:func:`~wrinkle_vis.plotting.add_skull` name them).

Each handle is a ``vtkHandleWidget`` whose ``vtkPolygonalSurfacePointPlacer`` keeps it on its
layer's surface under the mouse. Skin handles slide on the skin as drawn (deformed by the
current expression) and report the REST position under them, the muscle's parameter, by
carrying the barycentric coordinates of the deformed triangle over to the rest triangle.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import pyvista as pv
import vtk

from wrinkle_vis.core import editing
from wrinkle_vis.core.editing import created
from wrinkle_vis.core.face import FaceModel, FaceState
from wrinkle_vis.core.mesh import (
    TriangleSurface,
    barycentric_points,
    closest_points,
    surface_coordinates,
)
from wrinkle_vis.core.muscle import Muscle
from wrinkle_vis.core.registry import TypeLookup
from wrinkle_vis.core.units import millimetre as millimetre  # moved there; kept here

__all__ = ["GenericWidget", "Handle", "LinearWidget", "PlacementWidget", "SheetWidget",
           "boundary_lines", "handles_for", "layer_of", "register_widget", "snapped",
           "snapped_points", "spherical_sector", "widget_factory"]

#: Handle colours by layer, and the colours of the AOI and the wrinkling region.
COLORS = {"skin": "#1f5fbf", "skull": "#8a1c1c", "aoi": "#2a9d8f", "region": "#e9c46a"}


OnMove = Callable[["Handle", np.ndarray, bool], None]


@dataclass(frozen=True)
class Handle:
    """One draggable point of a muscle: ``param`` (row ``index`` of a line) on ``layer``."""

    param: str
    index: int | None
    layer: str  # "skin" or "skull"

    @property
    def label(self) -> str:
        """``param`` or ``param[index]``."""
        return self.param if self.index is None else f"{self.param}[{self.index}]"

    def value(self, muscle: Muscle) -> np.ndarray:
        """``(3,)``: the handle's point in ``muscle`` (a rest position)."""
        arr = np.asarray(getattr(muscle, self.param), dtype=float)
        return arr if self.index is None else arr[self.index]


def layer_of(muscle: Muscle | type, param: str) -> str:
    """The surface point parameter ``param`` of ``muscle`` (a muscle or its type) is declared
    on (:meth:`Muscle.point_surfaces`): ``"skin"`` or ``"skull"``.
    """
    return muscle.point_surfaces()[param]


def handles_for(muscle: Muscle) -> tuple[Handle, ...]:
    """A handle per point of each point parameter (two for a line), on its declared
    surface (:meth:`Muscle.point_surfaces`).
    """
    out = []
    for param, layer in muscle.point_surfaces().items():
        arr = np.asarray(getattr(muscle, param), dtype=float)
        rows = [None] if arr.ndim == 1 else range(len(arr))
        out += [Handle(param, i, layer) for i in rows]
    return tuple(out)


# ---------------------------------------------------------------------- the registry
def register_widget(muscle_type: type, factory: Callable | None = None):
    """Use ``factory`` (a :class:`PlacementWidget` subclass) for ``muscle_type`` and its
    subclasses, over what the type declares in its ``widget`` attribute. Usable as a
    decorator: ``@register_widget(MyMuscle)``.
    """
    return _LOOKUP.register(muscle_type, factory)


def widget_factory(muscle_type: type) -> Callable:
    """The widget factory of a muscle type, looked up along its class hierarchy
    (:class:`~wrinkle_vis.core.registry.TypeLookup`): a factory registered with
    :func:`register_widget`, then the class's own ``widget = "module:attribute"``, else
    :class:`GenericWidget`. ``ImportError`` names a declaration that cannot be imported.
    """
    return _LOOKUP(muscle_type)


# ---------------------------------------------------------------------- drawing helpers
def boundary_lines(surface: TriangleSurface, mask: np.ndarray, points=None) -> pv.PolyData:
    """The outline of the patch of triangles whose three vertices are in ``mask``.

    Parameters
    ----------
    surface : TriangleSurface
        The triangles (and the cached edges of :attr:`TriangleSurface.triangle_edges`).
    mask : (n,) bool
        The vertices of the region.
    points : (n, 3) float, optional
        Vertex positions to draw at (default the surface's).

    Returns
    -------
    pyvista.PolyData
        Line segments along the edges that belong to exactly one patch triangle (empty when
        the patch is empty).
    """
    used, lines = boundary_topology(surface, mask)
    if not len(used):
        return pv.PolyData()
    pts = surface.points if points is None else np.asarray(points, dtype=float)
    return pv.PolyData(pts[used], lines=lines)


def boundary_topology(surface: TriangleSurface, mask: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """What :func:`boundary_lines` draws, without its points: ``(u,)`` the vertices the
    outline uses (sorted) and its VTK line cells ``(3 e,)`` (``2, a, b`` per edge, into
    those vertices). Depends on the surface's triangles and ``mask`` alone, so an outline
    found once is moved with the skin by writing ``points[used]``.
    """
    patch = mask[surface.triangles].all(axis=1)
    counts = np.bincount(surface.triangle_edges[patch].ravel(), minlength=len(surface.edges))
    edges = surface.edges[counts == 1]
    if not len(edges):
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    used, inverse = np.unique(edges, return_inverse=True)
    lines = np.hstack([np.full((len(edges), 1), 2), inverse.reshape(-1, 2)]).ravel()
    return used, lines


def spherical_sector(apex, axis, radius: float, half_angle_deg: float,
                     resolution: int = 24) -> pv.PolyData:
    """A cone of half-angle ``half_angle_deg`` from ``apex`` along ``axis``, closed by a
    spherical cap of ``radius``: the linear muscle's AOI.
    """
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = np.radians(np.linspace(0.0, half_angle_deg, resolution // 3 + 2))
    t = np.linspace(0.0, 2 * np.pi, resolution, endpoint=False)
    ring = np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2
    cap = (np.cos(phi)[:, None, None] * axis + np.sin(phi)[:, None, None] * ring) * radius
    pts = np.vstack([np.asarray(apex, float)[None], (cap + apex).reshape(-1, 3)])
    m = len(t)
    faces = []
    for i in range(len(phi) - 1):  # cap quads between rings i and i + 1
        for j in range(m):
            a, b = 1 + i * m + j, 1 + i * m + (j + 1) % m
            faces += [4, a, b, b + m, a + m]
    last = 1 + (len(phi) - 1) * m
    for j in range(m):  # the cone's side, from the apex to the cap's rim
        faces += [3, 0, last + (j + 1) % m, last + j]
    return pv.PolyData(pts, faces=np.array(faces))


# ---------------------------------------------------------------------- the widgets
class PlacementWidget:
    """Handles for one muscle's points, and its AOI and wrinkling region drawn.

    Parameters
    ----------
    views : mapping of str to pyvista.Plotter
        ``"skin"``, ``"muscles"`` and ``"skull"`` views (see the module docstring).
    muscle : Muscle
        The muscle to place.
    state : FaceState
        The frame on display (its skin, deformed, is where skin handles slide).
    on_move : callable, optional
        ``on_move(handle, rest_point, finished)`` while a handle is dragged (``finished``
        False) and once when it is let go (True). ``rest_point`` is ``(3,)``: on the rest
        skin for skin handles, on the skull for skull handles.
    on_start : callable, optional
        ``on_start(handle)`` when a drag starts.

    Notes
    -----
    Subclasses override :meth:`handles` (which points, on which layer) and
    :meth:`aoi_meshes` (the shapes drawn in the muscles view).
    """

    handle_size = 18.0

    def __init__(self, views: Mapping[str, pv.Plotter], muscle: Muscle, state: FaceState,
                 on_move: OnMove | None = None, on_start: Callable | None = None):
        self.views = views
        self.on_move = on_move
        self.on_start = on_start
        self.muscle = muscle
        self.state = state
        self.widgets: dict[Handle, vtk.vtkHandleWidget] = {}
        self._placers: dict[Handle, vtk.vtkPolygonalSurfacePointPlacer] = {}
        self._overlays: dict[tuple[pv.Plotter, str], pv.Actor] = {}  # the overlays drawn
        self._drawn: tuple[FaceState, TriangleSurface] | None = None
        # the overlays that depend on the rest skin and the muscle alone (_outlines, _volumes)
        self._outline_cache: tuple[TriangleSurface, Muscle, dict] | None = None
        self._volume_cache: tuple[Muscle, dict[str, pv.PolyData]] | None = None
        for handle in self.handles(muscle):
            self._add_handle(handle)
        self.update(muscle, state)

    # -------------------------------------------------------------- what subclasses say
    @classmethod
    def handles(cls, muscle: Muscle) -> tuple[Handle, ...]:
        """The handles for ``muscle`` (default: :func:`handles_for`)."""
        return handles_for(muscle)

    def aoi_meshes(self, muscle: Muscle) -> dict[str, pv.PolyData]:
        """Named shapes of the muscle's area of influence for the muscles view."""
        return {}

    @classmethod
    def create(cls, muscle_type: type, name: str, face: FaceModel, at) -> Muscle:
        """A new muscle of ``muscle_type`` called ``name`` with its insertion at ``at``
        ``(3,)`` on the skin: the type's own :meth:`Muscle.create` (the core's), in the
        face's unit (:func:`created`).

        Raises
        ------
        NotImplementedError
            When the type does not know how to make one; the message says what to do.
        """
        return created(muscle_type, name, face, at)

    # -------------------------------------------------------------- handles
    def _add_handle(self, handle: Handle) -> None:
        plotter = self.views[handle.layer]
        placer = vtk.vtkPolygonalSurfacePointPlacer()
        placer.AddProp(self._surface_actor(handle))
        rep = vtk.vtkPointHandleRepresentation3D()
        self._placers[handle] = placer
        rep.SetPointPlacer(placer)
        rep.SetHandleSize(self.handle_size)
        rep.AllOn()
        rep.GetProperty().SetColor(pv.Color(COLORS[handle.layer]).float_rgb)
        rep.GetProperty().SetLineWidth(3)
        rep.GetSelectedProperty().SetColor(1.0, 0.5, 0.0)
        rep.GetSelectedProperty().SetLineWidth(4)
        widget = vtk.vtkHandleWidget()
        widget.SetInteractor(plotter.iren.interactor)
        widget.SetRepresentation(rep)
        widget.SetCurrentRenderer(plotter.renderer)
        widget.AddObserver("StartInteractionEvent", lambda *_: self._started(handle))
        widget.AddObserver("InteractionEvent", lambda *_: self._moved(handle, False))
        widget.AddObserver("EndInteractionEvent", lambda *_: self._moved(handle, True))
        widget.EnabledOn()
        self.widgets[handle] = widget

    def _surface_actor(self, handle: Handle):
        """The actor a handle slides on: its layer's, or the skin's in a view without it
        (a face with no skull puts skull handles on the skin).
        """
        actors = self.views[handle.layer].actors
        return actors[handle.layer] if handle.layer in actors else actors["skin"]

    def rebind(self, state: FaceState) -> None:
        """Follow scenes that were cleared and built again: slide on the new skin and skull
        actors and show the handles again. Safe during a drag (the widgets stay; closing a
        widget inside its own event would crash VTK).
        """
        for handle, widget in self.widgets.items():
            plotter = self.views[handle.layer]
            placer = self._placers[handle]
            placer.RemoveAllProps()
            placer.AddProp(self._surface_actor(handle))
            rep = widget.GetRepresentation()
            if not plotter.renderer.HasViewProp(rep):
                plotter.renderer.AddViewProp(rep)
        self._overlays = {}
        self.update(self.muscle, state)

    def _started(self, handle: Handle) -> None:
        if self.on_start is not None:
            self.on_start(handle)

    def _moved(self, handle: Handle, finished: bool) -> None:
        if self.on_move is not None:
            self.on_move(handle, self.rest_point(handle), finished)

    def position(self, handle: Handle) -> np.ndarray:
        """``(3,)``: where the handle is drawn (on the deformed skin, or the skull)."""
        return np.array(self.widgets[handle].GetRepresentation().GetWorldPosition())

    def rest_point(self, handle: Handle) -> np.ndarray:
        """``(3,)``: the rest position under the handle (what the muscle's parameter takes)."""
        drawn = self.position(handle)
        if handle.layer != "skin":
            return drawn
        tri, bary = surface_coordinates(self._drawn_skin(), drawn[None])
        return barycentric_points(self.state.face.skin, tri, bary)[0]

    def _drawn_skin(self) -> TriangleSurface:
        """The skin as drawn in the frame (deformed), kept with its search tree until the
        frame changes: every mouse move of a drag looks up the handle on it.
        """
        if self._drawn is None or self._drawn[0] is not self.state:
            self._drawn = (self.state, self.state.face.skin.with_points(self.state.points))
        return self._drawn[1]

    def drawn_points(self, handles, rests) -> np.ndarray:
        """``(k, 3)``: where rest points ``(k, 3)`` of ``handles`` are drawn in the frame."""
        out = np.array(rests, dtype=float).reshape(-1, 3)
        on_skin = np.array([h.layer == "skin" for h in handles], dtype=bool)
        if on_skin.any():
            skin = self.state.face.skin  # the rest skin: its search tree is kept
            tri, bary = surface_coordinates(skin, out[on_skin])
            out[on_skin] = barycentric_points(skin, tri, bary, points=self.state.points)
        return out

    # -------------------------------------------------------------- drawing
    def update(self, muscle: Muscle, state: FaceState) -> None:
        """Follow a new version of the muscle or a new frame: move the handles, redraw the
        AOI and the region (nothing is rendered; the caller renders).
        """
        self.muscle, self.state = muscle, state
        handles = list(self.widgets)
        drawn = self.drawn_points(handles, [h.value(muscle) for h in handles])
        for handle, point in zip(handles, drawn, strict=True):
            self.widgets[handle].GetRepresentation().SetWorldPosition(point)
        self._draw_overlays()

    def _draw_overlays(self) -> None:
        outlines = self._outlines()
        for used, mesh in outlines.values():
            if len(used):  # just above the skin as drawn
                mesh.points = self.state.points[used] + 0.4 * self.state.normals[used]
        for view in ("skin", "muscles"):
            for kind, (_, mesh) in outlines.items():
                self._overlay(view, f"widget:{kind}", mesh, color=COLORS[kind], line_width=3)
        for name, mesh in self._volumes().items():
            # opaque lines: translucency would cost most of the view's render in software
            self._overlay("muscles", f"widget:{name}", mesh, color=COLORS["aoi"],
                          style="wireframe", line_width=1.5)

    def _outlines(self) -> dict[str, tuple[np.ndarray, pv.PolyData]]:
        """The muscle's AOI and region outlines on the frame's skin: ``{kind: (used,
        mesh)}``, the vertices each uses and its mesh, whose points each frame rewrites.
        Their edges depend on the rest skin and the muscle alone: found once for both
        (kept while the skin is the same object and the muscle equal), not every frame.
        """
        skin, muscle = self.state.face.skin, self.muscle
        cached = self._outline_cache
        if cached is not None and cached[0] is skin and cached[1] == muscle:
            return cached[2]
        data = self.state.face.muscle_data(muscle)
        outlines = {}
        for kind, ids in (("aoi", data.aoi), ("region", data.region)):
            mask = np.zeros(skin.n_points, dtype=bool)
            mask[ids] = True
            used, lines = boundary_topology(skin, mask)
            mesh = pv.PolyData(skin.points[used], lines=lines) if len(used) else pv.PolyData()
            outlines[kind] = (used, mesh)
        self._outline_cache = (skin, muscle, outlines)
        return outlines

    def _volumes(self) -> dict[str, pv.PolyData]:
        """:meth:`aoi_meshes` of the muscle, built once per muscle (they do not move with
        the skin).
        """
        cached = self._volume_cache
        if cached is None or cached[0] != self.muscle:
            self._volume_cache = cached = (self.muscle, self.aoi_meshes(self.muscle))
        return cached[1]

    def _overlay(self, view: str, name: str, mesh: pv.PolyData, **kwargs) -> None:
        """Draw ``mesh`` as overlay ``name`` in ``view``: into the actor drawn there before
        (kept, not looked up by name: PyVista walks every prop of the view for that, about
        0.1 ms in the muscles view, six overlays a mouse move), else a new actor.
        """
        plotter = self.views[view]
        key = (plotter, name)
        if mesh.n_points == 0:
            plotter.remove_actor(name, render=False)
            self._overlays.pop(key, None)
            return
        actor = self._overlays.get(key)
        if actor is not None and plotter.renderer.HasViewProp(actor):
            if actor.mapper.dataset is not mesh:  # the same mesh moved: drawn as it is
                actor.mapper.dataset = mesh  # as replace_mesh does
            return
        self._overlays[key] = plotter.add_mesh(mesh, name=name, pickable=False,
                                               reset_camera=False, render=False,
                                               lighting=False, **kwargs)

    def close(self) -> None:
        """Remove the handles and the overlays (safe to call twice)."""
        for widget in self.widgets.values():
            widget.EnabledOff()
            widget.RemoveAllObservers()
            widget.SetInteractor(None)
        self.widgets, self._placers = {}, {}
        for plotter, name in self._overlays:
            if not getattr(plotter, "_closed", False):
                plotter.remove_actor(name, render=False)
        self._overlays = {}


class GenericWidget(PlacementWidget):
    """For a muscle type that declares no widget: a handle per point parameter (both ends
    of a line) on the surface the parameter declares, and the AOI and wrinkling region
    outlined on the skin.
    """


class LinearWidget(PlacementWidget):
    """Linear muscle: insertion on the skin, attachment on the skull, and the AOI, the
    cone of angle Φ and radius R around the fibre, drawn in the muscles view.
    """

    def aoi_meshes(self, muscle) -> dict[str, pv.PolyData]:
        """The cone of half-angle Φ capped at radius R, from the attachment."""
        return {"aoi_volume": spherical_sector(muscle.attachment, muscle.fibre, muscle.radius,
                                               muscle.max_angle_deg)}


class SheetWidget(PlacementWidget):
    """Sheet muscle: the two ends of the insertion line on the skin and of the attachment
    line on the skull, and the AOI, the rectangle of length L_s and width W_s from the
    attachment line's centre, swept to its depth bound on both sides, in the muscles view.
    """

    def aoi_meshes(self, muscle) -> dict[str, pv.PolyData]:
        """The AOI rectangle and the box of its depth bound."""
        f, s, n = muscle.frame
        length, width, depth = muscle.length_value, muscle.width_value, muscle.depth_value
        c = muscle.attachment_center
        corners = [c + a * length * f + b * 0.5 * width * s + d * depth * n
                   for d in (-1, 1) for b in (-1, 1) for a in (0, 1)]
        box = pv.PolyData(np.array(corners), faces=np.array(
            [4, 0, 1, 3, 2, 4, 4, 6, 7, 5, 4, 0, 4, 5, 1, 4, 2, 3, 7, 6, 4, 0, 2, 6, 4,
             4, 1, 5, 7, 3]))
        rect = pv.PolyData(np.array([c + a * length * f + b * 0.5 * width * s
                                     for b in (-1, 1) for a in (0, 1)]),
                           faces=np.array([4, 0, 1, 3, 2]))
        return {"aoi_volume": box, "aoi_rectangle": rect}


# ---------------------------------------------------------------------- placing muscles
def snapped(muscle: Muscle, face: FaceModel, like: Muscle | None = None) -> Muscle:
    """The muscle with its points moved onto the face's skin (at rest) and skull as its
    type declares them: :func:`wrinkle_vis.core.editing.snapped` on ``face``'s surfaces
    (see there for ``like``).
    """
    return editing.snapped(muscle, {"skin": face.skin, "skull": face.skull}, like=like)


def snapped_points(surface, points) -> tuple:
    """``((3,), ...)``: the closest points of ``surface`` to ``points``, as tuples."""
    return tuple(map(tuple, closest_points(surface, np.asarray(points, float))))


#: The widget factories by muscle type (:func:`register_widget`, :func:`widget_factory`).
_LOOKUP = TypeLookup("widget", GenericWidget, "Class")
_WIDGETS = _LOOKUP.registered
