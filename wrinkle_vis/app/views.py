"""The three linked views' scenes, drawn from a session (no Qt: works on off-screen plotters).

:meth:`LinkedViews.draw` rebuilds a scene only when what it shows changes (the field, the
selected muscle, the skin's triangles, the set of muscles); otherwise it writes the new frame
into the drawn meshes' VTK arrays, redraws only the muscles that were edited, and moves the
selected muscle's placement widget. :meth:`LinkedViews.render` then renders the views that
changed. The app's window and the drag benchmark both use it. The skin view can show plain
skin (no field) and be lit by a raking light (:meth:`LinkedViews.set_raking_light`).
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from ..core.face import FaceState
from ..plotting import (
    add_attachments,
    add_muscle,
    add_muscles,
    add_raking_light,
    add_skin,
    add_skull,
    attachment_points,
    clear_scene,
    field_range,
    muscle_mesh,
    replace_mesh,
)
from ..plotting.fields import field_info
from ..plotting.polydata import field_array_name
from ..widgets import widget_factory

__all__ = ["LinkedViews"]


class LinkedViews:
    """Skin (with the field), muscles (over a translucent skin) and skull views.

    Parameters
    ----------
    skin, muscles, skull : pyvista.Plotter
        The three views (``QtInteractor`` in the app, off-screen plotters elsewhere).
    on_move, on_start : callable, optional
        Passed to each placement widget (see :class:`~wrinkle_vis.widgets.PlacementWidget`).
    """

    def __init__(self, skin: pv.Plotter, muscles: pv.Plotter, skull: pv.Plotter,
                 on_move=None, on_start=None):
        self.skin_view, self.muscle_view, self.skull_view = skin, muscles, skull
        self.on_move, self.on_start = on_move, on_start
        self.placement = None
        self.raking_light = False
        self._key = None
        self._skin_mesh = self._ghost_mesh = None
        self._muscle_meshes: dict[str, pv.PolyData] = {}
        self._drawn_muscles: dict = {}
        self._drawn_activation: dict[str, float] = {}
        self._attachments = None
        self._changed = {"skin", "muscles", "skull"}

    @property
    def plotters(self) -> tuple[pv.Plotter, pv.Plotter, pv.Plotter]:
        """The skin, muscles and skull views."""
        return self.skin_view, self.muscle_view, self.skull_view

    def invalidate(self) -> None:
        """Rebuild every scene at the next :meth:`draw`."""
        self._key = None

    # ------------------------------------------------------------------ drawing
    def draw(self, session, state: FaceState, *, wireframe: bool = False,
             plain: bool = False) -> bool:
        """Draw ``state`` of ``session`` (nothing is rendered); returns whether the scenes
        were rebuilt. ``plain`` draws the skin view's skin without its field.
        """
        face = session.face
        key = (id(face.skin), id(state.face.skin), face.muscle_names, session.field,
               session.muscle, wireframe, plain)
        if key != self._key:
            self._rebuild(session, state, wireframe, plain)
            self._key = key
            return True
        self._update_in_place(session, state, plain)
        return False

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
            self.skin_view.enable_lightkit(only_active=True)

    def _rebuild(self, session, state: FaceState, wireframe: bool, plain: bool) -> None:
        face = session.face
        keep = self.placement is not None and session.muscle == self.placement.muscle.name \
            and type(face.muscle(session.muscle)) is type(self.placement.muscle)
        if not keep:
            self.close_placement()
        clear_scene(self.skin_view)
        if self.raking_light:
            self._light_skin()
        actor = add_skin(self.skin_view, state, None if plain else session.field,
                         None if plain else session.muscle, show_edges=wireframe)
        self._skin_mesh = actor.mapper.dataset
        clear_scene(self.muscle_view)
        self._ghost_mesh = add_skin(self.muscle_view, state, None, opacity=0.25).mapper.dataset
        self._muscle_meshes = add_muscles(self.muscle_view, face, state.activations)
        self._drawn_activation = dict(state.activations)
        self._drawn_muscles = {m.name: m for m in face.muscles}
        clear_scene(self.skull_view)
        self._attachments = attachment_points(face)
        if face.skull is not None:
            add_skull(self.skull_view, face)
        if keep:  # e.g. during a drag: the widget in use must not be destroyed
            self.placement.muscle = face.muscle(session.muscle)
            self.placement.rebind(state)
        else:
            self._make_placement(session, state)
        self._changed = {"skin", "muscles", "skull"}

    def _update_in_place(self, session, state: FaceState, plain: bool = False) -> None:
        """Write the frame into the drawn meshes (``add_mesh`` renders a shallow copy that
        shares their VTK arrays) and redraw only the muscles that were edited.
        """
        face = session.face
        if plain:
            _write(self._skin_mesh, state.points)
        else:
            array = field_array_name(session.field, session.muscle)
            values = state.W if session.muscle is None else \
                state.fields[session.muscle][session.field]
            _write(self._skin_mesh, state.points, array, values)
            self.skin_view.actors["skin"].mapper.scalar_range = field_range(
                field_info(session.field), values)
        _write(self._ghost_mesh, state.points)
        for m in face.muscles:
            if self._drawn_muscles.get(m.name) is not m:  # edited: draw it again
                mesh = muscle_mesh(m, state.activations[m.name])
                if not replace_mesh(self.muscle_view, f"muscle:{m.name}", mesh):
                    mesh = add_muscle(self.muscle_view, m, state.activations[m.name])
                self._muscle_meshes[m.name] = mesh
                self._drawn_muscles[m.name] = m
            elif self._drawn_activation.get(m.name) != state.activations[m.name]:
                _write(self._muscle_meshes[m.name], None, "activation",
                       state.activations[m.name])  # only when it changed: each write
                # re-runs the actor's scalars pipeline at the next render
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

    def render(self, only_changed: bool = False, skip=()) -> None:
        """Render the views: all, or only those the last :meth:`draw` changed, less the
        plotters in ``skip`` (the view of a handle being dragged: its widget renders it).
        """
        views = dict(zip(("skin", "muscles", "skull"), self.plotters, strict=True))
        for name, p in views.items():
            if not getattr(p, "_closed", False) and not any(p is q for q in skip) and (
                    not only_changed or name in self._changed):
                p.render_window.Render()

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
    def _make_placement(self, session, state: FaceState) -> None:
        if session.muscle is None:
            return
        muscle = session.face.muscle(session.muscle)
        views = {"skin": self.skin_view, "muscles": self.muscle_view,
                 "skull": self.skull_view if session.face.skull is not None
                 else self.skin_view}
        self.placement = widget_factory(type(muscle))(
            views, muscle, state, on_move=self.on_move, on_start=self.on_start)

    def close_placement(self) -> None:
        """Remove the placement widget, if any."""
        if self.placement is not None:
            self.placement.close()
            self.placement = None


def _write(mesh, points=None, array: str | None = None, values=None) -> None:
    """Write into a mesh's existing VTK buffers (shared with PyVista's shallow copies)."""
    if points is not None:
        mesh.points[:] = points
        mesh.GetPoints().Modified()
    if array is not None:
        mesh.point_data[array][:] = values
        mesh.GetPointData().GetArray(array).Modified()
    mesh.Modified()
