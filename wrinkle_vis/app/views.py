"""The three linked views' scenes, drawn from a frame and the display options (no Qt: works
on off-screen plotters).

:meth:`LinkedViews.draw` rebuilds a scene only when what it shows changes (the field, the
selected muscle, the set of muscles); otherwise it writes the new frame into the drawn
meshes' VTK arrays (points, vertex normals, the field), or, when a refined frame has other
triangles than the last, gives the same actors new meshes (:func:`redraw_kind` decides),
redraws only the muscles that were edited, and moves the selected muscle's placement
widget. :meth:`LinkedViews.render` then renders the views that changed. The app's window
and the drag benchmark both use it. The skin view can show plain skin (no field) and be lit
by a raking light (:meth:`LinkedViews.set_raking_light`), its colour range can be given
(else each frame's own), and :meth:`LinkedViews.save_image` renders a view at any size
without the placement widget.
"""

from __future__ import annotations

import weakref
from pathlib import Path

import numpy as np
import pyvista as pv
from vtkmodules.vtkRenderingCore import vtkCamera

from ..core.face import FaceModel, FaceState
from ..core.units import face_unit
from ..plotting import (
    add_attachments,
    add_muscle,
    add_muscles,
    add_raking_light,
    add_skin,
    add_skin_mesh,
    add_skull,
    attachment_points,
    clear_scene,
    field_range,
    muscle_mesh,
    remove_raking_light,
    replace_mesh,
)
from ..plotting.bars import add_field_bar, fit_bar_labels
from ..plotting.fields import field_info
from ..plotting.polydata import field_array_name
from ..plotting.writers import save_image
from ..widgets import widget_factory
from .models import DisplayOptions

__all__ = ["VIEWS", "LinkedViews", "add_field_bar", "ghost_skin", "redraw_kind"]

#: The views, in order.
VIEWS = ("skin", "muscles", "skull")
#: The name of the probe marker's actor in the skin view (``_picked``: saved images leave
#: it out, as PyVista's own picked point).
PROBE_ACTOR = "_picked_probe"


class LinkedViews:
    """Skin (with the field), muscles (over a translucent skin) and skull views.

    Parameters
    ----------
    skin, muscles, skull : pyvista.Plotter
        The three views (the app's view widgets, :mod:`wrinkle_vis.app.viewwidget`;
        off-screen plotters elsewhere).
    on_move, on_start : callable, optional
        Passed to each placement widget (see :class:`~wrinkle_vis.widgets.PlacementWidget`).
    render_view : callable, optional
        ``render_view(plotter)`` renders one view for :meth:`render` (default
        ``plotter.render_window.Render()``; the app's views' ``render_now``, which a
        pyvistaqt widget needs to render once a frame, not twice).
    """

    def __init__(self, skin: pv.Plotter, muscles: pv.Plotter, skull: pv.Plotter,
                 on_move=None, on_start=None, render_view=None):
        self.skin_view, self.muscle_view, self.skull_view = skin, muscles, skull
        self.on_move, self.on_start = on_move, on_start
        self.placement = None
        self.raking_light = False
        # multisampling as the options last said (None: as the plotters' theme made it,
        # which the first draw replaces: PyVista's theme may turn it on)
        self.anti_aliasing: bool | None = None
        self._key = None
        self._topology = None  # (number of points, triangles) of the drawn skin
        self._ghost_topology = None  # the same of the muscles view's skin
        self.last_redraw: str | None = None  # what the last draw did (see redraw_kind)
        self._render_view = render_view or _render_now
        self._skin_mesh = self._ghost_mesh = None
        self._probe_mesh = None  # the probe's marker (show_probe)
        self._muscle_meshes: dict[str, pv.PolyData] = {}
        self._muscle_actors: dict = {}  # the actors that draw them
        self._drawn_muscles: dict = {}
        self._drawn_activation: dict[str, float] = {}
        self._attachments = None
        self._changed = {"skin", "muscles", "skull"}
        self._bar = None  # the skin view's scalar bar
        # before each render of the skin view (a redraw, a resize), fit the bar's labels
        this = weakref.ref(self)
        self._fit_observer = skin.renderer.AddObserver(
            "StartEvent", lambda *_: this() is not None and this()._fit_bar())
        # and the muscles view's activation bar, so that it is laid out for the view's
        # size whenever it was made (in place and rebuilt alike)
        self._fit_muscles_observer = muscles.renderer.AddObserver(
            "StartEvent", lambda *_: this() is not None and this()._fit_muscle_bars())

    def _fit_bar(self) -> None:
        bar = self._bar
        if bar is not None and self.skin_view.renderer.HasViewProp(bar):
            fit_bar_labels(bar, self.skin_view.renderer)

    def _fit_muscle_bars(self) -> None:
        renderer = self.muscle_view.renderer
        for bar in list(self.muscle_view.scalar_bars.values()):
            if renderer.HasViewProp(bar):
                fit_bar_labels(bar, renderer)

    @property
    def plotters(self) -> tuple[pv.Plotter, pv.Plotter, pv.Plotter]:
        """The skin, muscles and skull views."""
        return self.skin_view, self.muscle_view, self.skull_view

    def invalidate(self) -> None:
        """Rebuild every scene at the next :meth:`draw`."""
        self._key = None

    # ------------------------------------------------------------------ drawing
    def draw(self, state: FaceState, options: DisplayOptions | None = None,
             face: FaceModel | None = None) -> bool:
        """Draw frame ``state`` as ``options`` say (default :class:`DisplayOptions`: W's
        total; nothing is rendered); returns whether the scenes were rebuilt. ``face``:
        the face the frame is of (default ``state.face``; a refined frame's face is the
        refinement's, so the unrefined one is given: its skin, muscles and skull).

        The skin view shows ``options.field`` of ``options.muscle`` (plain skin with
        ``options.plain``) in ``options.cmap`` over ``options.clim`` (default: the field's
        own map; the frame's own range, :func:`field_range`), outlined with
        ``options.wireframe``, lit by the raking light with ``options.raking_light``; the
        three views multisample with ``options.anti_aliasing``; ``options.muscle``'s
        placement widget shows. How, :func:`redraw_kind` decides (kept in
        :attr:`last_redraw`): the scenes anew, new skin meshes under the same actors
        (other triangles: a refinement that split other triangles), or the frame written
        into the drawn meshes in place.
        """
        options = DisplayOptions() if options is None else options
        face = state.face if face is None else face
        self.apply_switches(options)
        unit = face_unit(face)
        key = (id(face.skin), face.muscle_names, options.field, options.muscle,
               options.wireframe, options.plain, options.cmap, unit)
        topology = (state.n_points, state.triangles)
        self.last_redraw = redraw_kind(self._key, self._topology, key, topology)
        if self.last_redraw == "scene":
            self._rebuild(face, state, options, unit)
            self._key = key
        else:
            self._update(face, state, options, self.last_redraw == "mesh")
        self._topology = topology
        return self.last_redraw == "scene"

    def apply_switches(self, options: DisplayOptions) -> None:
        """The raking light and the multisampling as ``options`` say (changed only where
        they differ from what is drawn; :meth:`draw` does it too). Renders nothing.
        """
        if options.raking_light != self.raking_light:
            self.set_raking_light(options.raking_light)
        if options.anti_aliasing != self.anti_aliasing:
            self.anti_aliasing = options.anti_aliasing
            for p in self.plotters:
                if options.anti_aliasing:
                    p.enable_anti_aliasing("msaa", multi_samples=8)
                else:
                    p.disable_anti_aliasing()
            self._changed = {"skin", "muscles", "skull"}

    @property
    def skin_mesh(self) -> pv.PolyData | None:
        """The mesh the skin view draws (its points and the field shown)."""
        return self._skin_mesh

    def show_probe(self, point, radius: float) -> None:
        """Mark the probed point ``(3,)`` on the skin view with a ball of ``radius`` (None:
        no mark); kept across redraws while shown, hidden from saved images. Renders
        nothing.
        """
        view = self.skin_view
        if point is None:
            if PROBE_ACTOR in view.actors:
                view.remove_actor(PROBE_ACTOR, render=False)
                self._changed.add("skin")
            self._probe_mesh = None
            return
        ball = pv.Sphere(radius=radius, center=np.asarray(point, float), theta_resolution=20,
                         phi_resolution=12)
        actor = view.actors.get(PROBE_ACTOR)
        if actor is not None and self._probe_mesh is not None \
                and actor.mapper.dataset is self._probe_mesh:
            self._probe_mesh.points = ball.points  # moved in place
        else:
            self._probe_mesh = ball
            view.add_mesh(ball, color="#ff00ff", name=PROBE_ACTOR, pickable=False,
                          reset_camera=False, render=False, smooth_shading=True)
        self._changed.add("skin")

    def scalar_range(self) -> tuple[float, float] | None:
        """The skin view's colour range now (None for plain skin)."""
        actor = self.skin_view.actors.get("skin")
        if actor is None or not actor.mapper.scalar_visibility:
            return None
        return tuple(float(x) for x in actor.mapper.scalar_range)

    def set_raking_light(self, on: bool) -> None:
        """Light the skin view with :func:`~wrinkle_vis.plotting.add_raking_light` (on) or
        the light kit (off); kept across rebuilds. Renders nothing.
        """
        self.raking_light = bool(on)
        self._light_skin()
        self._changed.add("skin")

    def _light_skin(self) -> None:
        if self.raking_light:
            add_raking_light(self.skin_view)
        else:
            remove_raking_light(self.skin_view)  # colour-mapped skin's material back too

    def _rebuild(self, face: FaceModel, state: FaceState, options: DisplayOptions,
                 unit: str) -> None:
        muscle = options.muscle
        keep = self.placement is not None and muscle == self.placement.muscle.name \
            and type(face.muscle(muscle)) is type(self.placement.muscle)
        if not keep:
            self.close_placement()
        clear_scene(self.skin_view)
        if self.raking_light:
            self._light_skin()
        field = None if options.plain else options.field
        info = field_info(options.field)
        actor = add_skin(self.skin_view, state, field, None if options.plain else muscle,
                         show_edges=options.wireframe, scalar_bar=False,
                         normals=state.normals, cmap=options.cmap or info.cmap)
        if field is not None:
            if options.clim is not None:
                actor.mapper.scalar_range = options.clim
            self._bar = add_field_bar(self.skin_view, actor.mapper,
                                      info.title(muscle, units=unit),
                                      info.display_title(muscle, unit))
        self._skin_mesh = actor.mapper.dataset
        self._rebuild_muscles(face, state)
        if keep:  # e.g. during a drag: the widget in use must not be destroyed
            self.placement.muscle = face.muscle(muscle)
            self.placement.rebind(state)
        else:
            self._make_placement(face, muscle, state)
        self._changed = {"skin", "muscles", "skull"}

    def _rebuild_muscles(self, face: FaceModel, state: FaceState) -> None:
        """The muscles view (the skin's ghost, the muscles tinted by their activations) and
        the skull view anew.
        """
        clear_scene(self.muscle_view)
        points, triangles, normals = ghost_skin(state, face.skin)
        self._ghost_mesh = _skin_polydata(points, triangles, normals)
        self._ghost_topology = (len(points), triangles)
        _translucent_shell(self.muscle_view,
                           add_skin_mesh(self.muscle_view, self._ghost_mesh, opacity=0.25))
        self._muscle_meshes = add_muscles(self.muscle_view, face, state.activations)
        actors = self.muscle_view.actors  # a dict PyVista builds at each access
        self._muscle_actors = {m.name: actors[f"muscle:{m.name}"] for m in face.muscles}
        for m in face.muscles:
            _tint(self._muscle_actors[m.name], state.activations[m.name])
        self._drawn_activation = dict(state.activations)
        self._drawn_muscles = {m.name: m for m in face.muscles}
        clear_scene(self.skull_view)
        self._attachments = attachment_points(face)
        if face.skull is not None:
            add_skull(self.skull_view, face)

    def _update(self, face: FaceModel, state: FaceState, options: DisplayOptions,
                remesh: bool) -> None:
        """Draw a frame in the scenes as they are: write it into the drawn skin meshes
        (points, vertex normals, the field shown: the mappers draw these very meshes), or,
        with ``remesh`` (other triangles), give the skin view's actor a new mesh of it
        (mapper, lookup table, scalar bar and properties kept); the same for the muscles
        view's skin (:func:`ghost_skin`); then the muscles, the attachments and the
        placement widget.
        """
        array, values = _shown(options, state)
        if remesh:
            self._skin_mesh = _skin_polydata(state.points, state.triangles, state.normals,
                                             array, values)
            replace_mesh(self.skin_view, "skin", self._skin_mesh)
        else:
            _write(self._skin_mesh, state.points, array, values, state.normals)
        if not options.plain:
            self.skin_view.actors["skin"].mapper.scalar_range = options.clim or field_range(
                field_info(options.field), values)
        points, triangles, normals = ghost_skin(state, face.skin)
        topology = (len(points), triangles)
        if redraw_kind(0, self._ghost_topology, 0, topology) == "points":
            _write(self._ghost_mesh, points, normals=normals)
        else:
            self._ghost_mesh = _skin_polydata(points, triangles, normals)
            replace_mesh(self.muscle_view, "skin", self._ghost_mesh)
        self._ghost_topology = topology
        self._update_muscles(face, state)

    def _update_muscles(self, face: FaceModel, state: FaceState) -> None:
        """Redraw the muscles that were edited, recolour those whose activation changed,
        move the attachments and the placement widget.
        """
        for m in face.muscles:
            a = state.activations[m.name]
            if self._drawn_muscles.get(m.name) is not m:  # edited: draw it again
                mesh = muscle_mesh(m, a)
                if not replace_mesh(self.muscle_view, f"muscle:{m.name}", mesh):
                    mesh = add_muscle(self.muscle_view, m, a)
                self._muscle_meshes[m.name] = mesh
                self._drawn_muscles[m.name] = m
                self._muscle_actors[m.name] = self.muscle_view.actors[f"muscle:{m.name}"]
                _tint(self._muscle_actors[m.name], a)
            elif self._drawn_activation.get(m.name) != a:
                _tint(self._muscle_actors[m.name], a)
        self._drawn_activation = dict(state.activations)
        self._changed = {"skin", "muscles"}
        attachments = attachment_points(face)
        if not np.array_equal(attachments, self._attachments):
            self._attachments = attachments
            if face.skull is not None:
                add_attachments(self.skull_view, face)
            self._changed.add("skull")
        if self.placement is not None:
            self.placement.update(face.muscle(self.placement.muscle.name), state)

    def render_skin(self) -> None:
        """Render the skin view alone (a probe marker moved)."""
        if not getattr(self.skin_view, "_closed", False):
            self._render_view(self.skin_view)

    def render(self, only_changed: bool = False, skip=()) -> None:
        """Render the views (with ``render_view``): all, or only those the last
        :meth:`draw` changed, less the plotters in ``skip`` (the view of a handle being
        dragged: its widget renders it).
        """
        render_view = self._render_view
        views = dict(zip(("skin", "muscles", "skull"), self.plotters, strict=True))
        for name, p in views.items():
            if not getattr(p, "_closed", False) and not any(p is q for q in skip) and (
                    not only_changed or name in self._changed):
                render_view(p)

    def save_image(self, view: str, path: str | Path, size: tuple[int, int]) -> Path:
        """Render view ``view`` (one of :data:`VIEWS`) off screen at ``size`` ``(width,
        height)`` pixels to the PNG ``path``: the same actors, lights and camera, less the
        placement widget's handles and outlines and the probe's marker.
        """
        width, height = (int(x) for x in size)
        if not (16 <= width <= 8192 and 16 <= height <= 8192):
            raise ValueError(f"image size {width} x {height}: each side must be in "
                             "16..8192 pixels")
        if view not in VIEWS:
            raise KeyError(f"unknown view {view!r}; views: {', '.join(VIEWS)}")
        source = dict(zip(VIEWS, self.plotters, strict=True))[view]
        renderer = source.renderer
        # held while in use: VTK gives back these very wrappers for their props
        hidden = [a for name, a in source.actors.items()
                  if name.startswith(("widget:", "_picked"))]
        if self.placement is not None:
            hidden += [w.GetRepresentation() for w in self.placement.widgets.values()]
        props = renderer.GetViewProps()
        props = [props.GetItemAsObject(i) for i in range(props.GetNumberOfItems())]
        off = pv.Plotter(off_screen=True, window_size=[width, height], lighting="none")
        try:
            target = off.renderer
            target.SetBackground(renderer.GetBackground())
            target.SetUseOIT(renderer.GetUseOIT())
            camera = vtkCamera()
            camera.DeepCopy(renderer.GetActiveCamera())
            target.SetActiveCamera(camera)
            target.camera_set = True  # else PyVista's first render resets (zooms out) it
            lights = renderer.GetLights()
            for i in range(lights.GetNumberOfItems()):
                target.AddLight(lights.GetItemAsObject(i))
            for prop in props:
                if prop.GetVisibility() and not any(prop is h for h in hidden):
                    target.AddViewProp(prop)
            target.ResetCameraClippingRange()
            image = off.screenshot(return_img=True)
        finally:
            off.renderer.RemoveAllViewProps()  # the actors are the views' own
            off.renderer.RemoveAllLights()
            off.close()
        save_image(image, path)  # atomic: a failed write keeps the old file
        return Path(path)

    # ------------------------------------------------------------------ dragging
    def begin_drag(self) -> None:
        """A handle is being dragged: leave out the muscles view's translucent skin until
        :meth:`end_drag` (translucency costs most of that view's render in software).
        """
        ghost = self.muscle_view.actors.get("skin")
        if ghost is not None:
            ghost.SetVisibility(False)
        self._changed.add("muscles")

    def end_drag(self) -> None:
        """The drag is over: show the muscles view's skin again."""
        ghost = self.muscle_view.actors.get("skin")
        if ghost is not None:
            ghost.SetVisibility(True)
        self._changed.add("muscles")

    # ------------------------------------------------------------------ placement
    def _make_placement(self, face: FaceModel, muscle: str | None, state: FaceState) -> None:
        if muscle is None:
            return
        m = face.muscle(muscle)
        views = {"skin": self.skin_view, "muscles": self.muscle_view,
                 "skull": self.skull_view if face.skull is not None else self.skin_view}
        self.placement = widget_factory(type(m))(
            views, m, state, on_move=self.on_move, on_start=self.on_start)

    def close_placement(self) -> None:
        """Remove the placement widget, if any."""
        if self.placement is not None:
            self.placement.close()
            self.placement = None


def redraw_kind(drawn_key, drawn_topology, key, topology) -> str:
    """How to draw a frame over the one drawn.

    Parameters
    ----------
    drawn_key, key : hashable
        What the scenes show (face, muscles, field, muscle, style), drawn and wanted;
        ``drawn_key`` None: nothing is drawn.
    drawn_topology, topology : (int, (m, 3) int) or None
        The number of skin points and the skin's triangles, drawn and of the frame (a
        refined frame has its own).

    Returns
    -------
    str
        ``"scene"``: build the scenes anew (what they show changed); ``"mesh"``: same
        scenes, other triangles, so new skin meshes under the same actors; ``"points"``:
        same triangles, so the frame is written into the drawn meshes in place.
    """
    if drawn_key is None or key != drawn_key or drawn_topology is None:
        return "scene"
    (n_drawn, drawn), (n, triangles) = drawn_topology, topology
    same = n == n_drawn and (triangles is drawn or (
        triangles.shape == drawn.shape and np.array_equal(triangles, drawn)))
    return "points" if same else "mesh"


def _shown(options: DisplayOptions, state: FaceState
           ) -> tuple[str | None, np.ndarray | None]:
    """The point array the skin view colours by and its values in ``state`` (None, None
    for plain skin).
    """
    if options.plain:
        return None, None
    return (field_array_name(options.field, options.muscle),
            state.field_values(options.field, options.muscle))


def _translucent_shell(plotter: pv.Plotter, actor) -> None:
    """Draw ``actor`` (a closed translucent skin over opaque muscles) as one shell: its
    back faces culled, blended over the opaque scene in one pass.

    The muscles view's skin is its only translucent surface; culling its back faces (the
    inside of the back of the head, which would show through its top) leaves one layer over
    most of the view, which plain alpha blending draws as order-independent translucency
    would (where the front of the face folds over itself, say the nose seen from the side,
    two layers blend in drawing order), without that technique's extra passes: 19 to 20 ms
    a render of the 317x739 view in software instead of 24 to 29
    (``benchmarks/bench_app_playback.py``).
    """
    actor.prop.backface_culling = True
    plotter.renderer.SetUseOIT(False)


def _tint(actor, activation: float) -> None:
    """Colour a muscle's actor by its ``activation`` as one colour, the one its lookup
    table (the activation colour map, which the view's scalar bar shows) gives, instead of
    mapping its mesh's constant ``activation`` array point by point.

    A new activation then changes one property: no scalars to map, no buffers to send to
    the renderer again (a write into the array re-sent the whole mesh of each muscle whose
    activation changed: 1.5 to 3 ms a render of that view while surprise plays, in software). The
    mesh's ``activation`` array keeps the value the muscle was drawn with.
    """
    mapper = actor.GetMapper()  # VTK's own calls: PyVista's wrappers cost more than this
    mapper.SetScalarVisibility(False)
    rgb = [0.0, 0.0, 0.0]
    mapper.GetLookupTable().GetColor(float(activation), rgb)
    actor.GetProperty().SetColor(rgb)


def _render_now(plotter) -> None:
    plotter.render_window.Render()


def ghost_skin(state: FaceState, skin) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The muscles view's translucent skin of ``state``: ``(n, 3)`` points, ``(m, 3)``
    triangles and ``(n, 3)`` vertex normals.

    A refined frame whose first vertices are the unrefined ``skin``'s (a refinement adds
    its vertices after them) gives ``skin``'s triangles on those vertices, at their
    refined positions: the view shows the skin at a quarter opacity as the muscles'
    context, where a refinement adds no visible detail, only triangles to blend (the most
    costly part of that view's render in software). Any other frame: its own skin.
    """
    n = skin.n_points
    rest = state.rest_points
    if state.n_points > n and (rest[:n] is skin.points or np.array_equal(rest[:n],
                                                                          skin.points)):
        return state.points[:n], skin.triangles, state.normals[:n]
    return state.points, state.triangles, state.normals


def _skin_polydata(points, triangles, normals, array: str | None = None,
                   values=None) -> pv.PolyData:
    """A skin mesh with its vertex normals (active) and, if named, the field ``values``
    as point array ``array`` (active scalars).
    """
    mesh = pv.PolyData.from_regular_faces(np.array(points, dtype=float), triangles)
    mesh.point_data["Normals"] = np.asarray(normals, dtype=float)
    mesh.GetPointData().SetActiveNormals("Normals")
    if array is not None:
        mesh.point_data[array] = np.asarray(values, dtype=float)
        mesh.set_active_scalars(array)
    return mesh


def _write(mesh, points=None, array: str | None = None, values=None, normals=None) -> None:
    """Write into a mesh's existing VTK buffers and mark them modified."""
    if points is not None:
        mesh.points[:] = points
        mesh.GetPoints().Modified()
    if array is not None:
        mesh.point_data[array][:] = values
        mesh.GetPointData().GetArray(array).Modified()
    if normals is not None:
        mesh.point_data["Normals"][:] = normals
        mesh.GetPointData().GetArray("Normals").Modified()
    mesh.Modified()
