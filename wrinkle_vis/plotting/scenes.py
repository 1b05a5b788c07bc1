"""Scenes of the three layers (skin, muscles, skull), cameras and off-screen rendering."""

from __future__ import annotations

import numpy as np
import pyvista as pv

from ..core.face import FaceModel, FaceState
from ..core.units import face_unit
from .bars import field_bar_args, fit_bar_labels, show_bar_title
from .fields import NAN_COLOR, field_info, field_range
from .finite import require_finite
from .glyphs import glyph_factory
from .polydata import field_array_name, to_polydata, to_surface_polydata
from .writers import IMAGE_SUFFIXES, check_target, save_image

__all__ = ["BONE", "CAMERAS", "LAYERS", "SKIN", "add_attachments", "add_muscle",
           "add_muscles", "add_raking_light", "add_skin", "add_skin_mesh", "add_skull",
           "attachment_points", "clear_scene", "evaluate", "keep_colours", "muscle_mesh",
           "raking_colour_material", "raking_lit", "remove_raking_light", "render_field",
           "replace_mesh", "set_camera", "testing_theme", "to_multiblock"]

SKIN = "#f1c9a5"
BONE = "#e3dac9"
LAYERS = ("skin", "muscles", "skull")
#: Named cameras: direction from the face to the eye (y up, face towards +z) and zoom.
CAMERAS = {
    "front": ((0.0, 0.0, 1.0), 1.0),
    "three_quarter": ((0.7, 0.1, 0.7), 1.0),
    "side": ((1.0, 0.0, 0.0), 1.0),
    "forehead": ((0.0, 0.15, 1.0), 2.2),
    "upper_face": ((0.0, 0.1, 1.0), 2.2),
}
#: Cameras that look at a height of the skin (fraction of its height from the bottom) on its
#: front, not at the middle of its bounds.
_CAMERA_HEIGHTS = {"forehead": 0.72, "upper_face": 0.6}
#: The same cameras on a face with landmarks: (height of the centre above the nasion, height
#: of the view), in units of the span between the outer eye corners, so a scan of a head
#: and shoulders in any unit is framed like the built-in face.
_LANDMARK_FRAMES = {"forehead": (0.5, 1.7), "upper_face": (0.25, 1.7)}
_FRAME_MARKS = ("nasion", "eye_outer_L", "eye_outer_R")


def testing_theme() -> pv.themes.DocumentTheme:
    """A fixed theme for image tests: fixed window size, no multisampling, no smoothing."""
    theme = pv.themes.DocumentTheme()
    theme.window_size = [400, 400]
    theme.anti_aliasing = None
    theme.multi_samples = 1
    theme.lighting = True
    theme.font.size = 12
    theme.font.title_size = 12
    theme.font.label_size = 10
    theme.nan_color = NAN_COLOR
    return theme


def clear_scene(plotter: pv.Plotter) -> None:
    """Remove every actor and scalar bar but keep the lights (``clear()`` drops them too).

    Nothing is rendered: the scene functions here add with ``render=False`` too, so a caller
    that rebuilds a scene renders once at the end.
    """
    plotter.clear()
    plotter.enable_lightkit(only_active=True)


#: The object name of the raking light's key light (how :func:`raking_lit` knows it).
RAKING_KEY = "wrinkle_vis.raking_key"
#: The raking light's headlight (fill) intensity, of the key light's 1.
RAKING_FILL = 0.35
#: Under the raking light, the least a colour map's colour shows (its ambient share): the
#: far side of a colour-mapped skin stays at least this bright, not dark grey.
RAKING_COLOUR_AMBIENT = 0.55


def add_raking_light(plotter: pv.Plotter, elevation_deg: float = 20.0,
                     azimuth_deg: float = 35.0, *, intensity: float = 1.0,
                     fill: float = RAKING_FILL) -> tuple[pv.Light, pv.Light]:
    r"""Light the active renderer for relief: a grazing key light and a weak fill.

    Replaces the renderer's lights (the light kit) with a directional key light fixed to the
    face (world coordinates: y up, the face looking towards +z) and a headlight as fill, so
    shallow furrows read on plain skin whatever their direction. The key light comes from

    .. math:: \mathbf{l} = (\cos e \sin a,\ \cos e \cos a,\ \sin e)

    (towards the light), ``e`` above the face's frontal plane, ``a`` from straight above
    towards the viewer's right. Horizontal furrows (surprise) need light from above
    (``a`` near 0), vertical ones (frown) light from the side (``a`` near 90): the default
    35 degrees shows both. The lower the elevation, the stronger the relief and the darker
    the far side of the head: 20 degrees shows the built-in face's sub-millimetre furrows
    and leaves the far half of the forehead readable. Undo with
    :func:`remove_raking_light`.

    Plain skin takes the light as it is; colour-mapped skin (a field) would darken to grey
    on the far side and wash towards white where key and fill add up, so it takes
    :data:`RAKING_COLOUR_MATERIAL` instead (:func:`keep_colours`), now and when added later.

    Parameters
    ----------
    plotter : pyvista.Plotter
        Its active renderer (the current subplot) is lit.
    elevation_deg : float
        Angle of the key light above the face's frontal plane; 0 grazes, 90 is frontal.
    azimuth_deg : float
        Angle from straight above towards the viewer's right (negative: the left).
    intensity, fill : float
        Key light and headlight intensities.

    Returns
    -------
    (pyvista.Light, pyvista.Light)
        The key light and the fill.
    """
    e, a = np.radians(elevation_deg), np.radians(azimuth_deg)
    towards = (np.cos(e) * np.sin(a), np.cos(e) * np.cos(a), np.sin(e))
    key = pv.Light(position=towards, focal_point=(0.0, 0.0, 0.0), intensity=intensity,
                   light_type="scene light")
    key.positional = False
    head = pv.Light(light_type="headlight", intensity=fill)
    key.SetObjectName(RAKING_KEY)  # marks the renderer raking-lit (enable_lightkit drops it)
    renderer = plotter.renderer
    renderer.remove_all_lights()
    renderer.add_light(key)
    renderer.add_light(head)
    keep_colours(renderer)
    return key, head


def remove_raking_light(plotter: pv.Plotter) -> None:
    """Undo :func:`add_raking_light`: the light kit again, and colour-mapped actors back
    to the plain material (``ambient=0``, ``diffuse=1``, as :func:`add_skin` draws them).
    """
    plotter.enable_lightkit(only_active=True)
    keep_colours(plotter.renderer)


def raking_lit(renderer) -> bool:
    """Whether ``renderer`` is lit by :func:`add_raking_light`."""
    return any(light.GetObjectName() == RAKING_KEY for light in renderer.GetLights())


def raking_colour_material(fill: float = RAKING_FILL) -> dict[str, float]:
    r"""``ambient`` and ``diffuse`` for colour-mapped actors under the raking light.

    A point of colour :math:`C` whose normal makes cosines :math:`c_k` with the key light
    and :math:`c_h` with the headlight (intensity ``fill``) shows
    :math:`C\,(a + d\,(c_k + f\,c_h))`: the ambient share :math:`a` keeps the colour at
    least :math:`a C` on the far side, and :math:`d = (1 - a)/(1 + f)` brings a point that
    faces both lights to :math:`C` exactly, so no colour clips towards white; what the
    diffuse share varies still shows the relief.
    """
    a = RAKING_COLOUR_AMBIENT
    return {"ambient": a, "diffuse": (1.0 - a) / (1.0 + fill)}


def keep_colours(renderer) -> None:
    """Give every colour-mapped actor of ``renderer`` (its mapper shows scalars) the
    material for its lights: :func:`raking_colour_material` under the raking light, else
    the plain one (``ambient=0``, ``diffuse=1``). Actors drawn in one colour keep theirs.
    """
    fill = max((light.GetIntensity() for light in renderer.GetLights()
                if light.LightTypeIsHeadlight()), default=RAKING_FILL)
    material = raking_colour_material(fill) if raking_lit(renderer) else \
        {"ambient": 0.0, "diffuse": 1.0}
    for actor in renderer.actors.values():
        mapper = getattr(actor, "mapper", None)
        if mapper is None or not mapper.GetScalarVisibility() or not hasattr(actor, "prop"):
            continue
        actor.prop.ambient = material["ambient"]
        actor.prop.diffuse = material["diffuse"]


def _fit_bar(plotter: pv.Plotter, options: dict, nan: bool = True,
             shown: str | None = None) -> None:
    """After ``add_mesh(..., **options)``: the scalar bar's NaN label, the title ``shown``
    on it (:func:`~wrinkle_vis.plotting.bars.show_bar_title`; default its name) and its tick
    labels fitted to the bar (:func:`~wrinkle_vis.plotting.bars.fit_bar_labels`).
    """
    title = (options.get("scalar_bar_args") or {}).get("title")
    if not options.get("show_scalar_bar") or title not in plotter.scalar_bars:
        return
    bar = plotter.scalar_bars[title]
    if nan:
        bar.SetNanAnnotation("undefined")
    if shown is not None:
        show_bar_title(bar, shown)
    fit_bar_labels(bar, plotter.renderer)


def evaluate(face: FaceModel, expression, intensity: float = 1.0, *, refine: bool = False,
             refine_angle_deg: float | None = None,
             refine_levels: int | None = None) -> FaceState:
    """``face.evaluate(expression, intensity, refine=refine, ...)`` with only the
    refinement options given (None: the model's defaults, :meth:`FaceModel.evaluate`),
    for the writers of images, animations and figures: a frame that is not finite is
    refused (:func:`~wrinkle_vis.plotting.finite.require_finite`).
    """
    options = {k: v for k, v in (("refine_angle_deg", refine_angle_deg),
                                 ("refine_levels", refine_levels)) if v is not None}
    state = face.evaluate(expression, intensity, refine=refine, **options)
    require_finite("the image", state)
    return state


def add_skin(plotter: pv.Plotter, state: FaceState, field: str | None = "W",
             muscle: str | None = None, *, opacity: float = 1.0, scalar_bar: bool = True,
             show_edges: bool = False, points=None, edge_color=None, normals=None,
             **mesh_kwargs):
    """Add the final skin of ``state``, coloured by ``field`` (of ``muscle``, or total W).

    ``field=None`` draws plain, matte skin. Undefined values (NaN) take :data:`NAN_COLOR` and
    the scalar bar labels them. ``points`` (``(n, 3)``) draws the skin elsewhere, e.g. at
    ``state.deformed_points`` (moved by the muscles, without wrinkles). ``normals``
    (``(n, 3)``, e.g. ``state.normals``) shades the skin smoothly with these vertex normals
    (point array ``Normals``) and draws the mesh itself, with no normals filter between it
    and the mapper, so that a caller can write a new frame into it in place (the app's
    views); by default a refined frame is shaded with its
    :meth:`~wrinkle_vis.core.state.FaceState.shading_normals` (the coarse skin's shading
    carried to the new vertices) and PyVista's smooth shading computes the others.
    ``mesh_kwargs`` go to ``add_mesh`` and override the choices here (``cmap="magma"``).
    Returns the actor.
    """
    drawn = state.points if points is None else points
    mesh = to_surface_polydata(state.face.skin, drawn)
    if normals is None and state.face.refined:  # the coarse skin's shading, carried over
        normals = state.shading_normals(drawn)
    if normals is not None:
        mesh.point_data["Normals"] = np.asarray(normals, dtype=float)
        mesh.GetPointData().SetActiveNormals("Normals")
    shading = _shading(mesh)
    if field is None:
        return add_skin_mesh(plotter, mesh, opacity=opacity, show_edges=show_edges,
                             edge_color=edge_color, **mesh_kwargs)
    info = field_info(field)
    values = np.asarray(state.field_values(field, muscle))  # checks field and muscle
    array = field_array_name(field, muscle)
    mesh.point_data[array] = values  # only the field shown: the others stay in the core
    mesh.set_active_scalars(array)
    options = dict(
        scalars=array, cmap=info.cmap, clim=field_range(info, values),
        nan_color=NAN_COLOR, opacity=opacity, show_edges=show_edges,
        edge_color=edge_color, show_scalar_bar=scalar_bar, name="skin", render=False,
        **shading,
        scalar_bar_args=field_bar_args(info.title(muscle, face_unit(state))) if scalar_bar
        else None)
    options.update(mesh_kwargs)
    actor = plotter.add_mesh(mesh, **options)
    _fit_bar(plotter, options, shown=info.display_title(muscle, face_unit(state)))
    if raking_lit(plotter.renderer):  # keep the colour map's colours (add_raking_light)
        keep_colours(plotter.renderer)
    return actor


def add_skin_mesh(plotter: pv.Plotter, mesh: pv.PolyData, *, opacity: float = 1.0,
                  show_edges: bool = False, edge_color=None, **mesh_kwargs):
    """Add ``mesh`` as plain, matte skin (actor ``skin``), shaded smoothly with its own
    vertex normals if it has them (else PyVista computes them); ``mesh_kwargs`` go to
    ``add_mesh`` and override these choices. Returns the actor.
    """
    options = dict(color=SKIN, opacity=opacity, show_edges=show_edges,
                   edge_color=edge_color, specular=0.0, diffuse=1.0, ambient=0.0,
                   name="skin", render=False, **_shading(mesh))
    return plotter.add_mesh(mesh, **{**options, **mesh_kwargs})


def _shading(mesh: pv.PolyData) -> dict:
    """``add_mesh`` arguments for smooth shading: with the mesh's own vertex normals, the
    mesh itself is drawn (no normals filter between it and the mapper: a write into it
    shows at the next render and runs no pipeline); else PyVista's smooth shading.
    """
    if mesh.GetPointData().GetNormals() is not None:
        return {"smooth_shading": False, "interpolation": "phong"}
    return {"smooth_shading": True}


def muscle_mesh(muscle, activation: float = 0.0) -> pv.PolyData:
    """The muscle as geometry: its type's glyph (:func:`~wrinkle_vis.plotting.glyph_factory`:
    a tapered fibre for a linear muscle, a ribbon of seven fibres for a sheet, a fibre
    through the declared points for a type with no glyph of its own).

    Point arrays: ``activation``, the activation everywhere, for colouring, and
    ``Normals``, the glyph's vertex normals when it has them (the active normals). What the
    glyph's filters left behind (a tube's radii, texture coordinates) is dropped.
    """
    mesh = glyph_factory(type(muscle))(muscle)
    normals = mesh.GetPointData().GetNormals()
    normals = None if normals is None else np.array(pv.convert_array(normals), dtype=float)
    mesh.clear_data()
    if normals is not None:
        mesh.point_data["Normals"] = normals
        mesh.GetPointData().SetActiveNormals("Normals")
    mesh.point_data["activation"] = np.full(mesh.n_points, float(activation))
    return mesh


def to_multiblock(state: FaceState) -> pv.MultiBlock:
    """The three layers of a frame as one ``pyvista.MultiBlock``.

    Blocks: ``skin`` (:func:`~wrinkle_vis.plotting.to_polydata`, every field as a point
    array), ``skull`` (when the face has one) and ``muscles`` (a block per muscle, from
    :func:`muscle_mesh`, with its ``activation``).
    """
    face = state.face
    muscles = pv.MultiBlock({m.name: muscle_mesh(m, state.activations[m.name])
                             for m in face.muscles})
    blocks = {"skin": to_polydata(state), "muscles": muscles}
    if face.skull is not None:
        skull = to_surface_polydata(face.skull)
        skull.point_data["Normals"] = face.skull.vertex_normals()
        skull.GetPointData().SetActiveNormals("Normals")
        blocks["skull"] = skull
    return pv.MultiBlock(blocks)


def add_muscles(plotter: pv.Plotter, face: FaceModel, activations=None, *,
                scalar_bar: bool = True) -> dict[str, pv.PolyData]:
    """Add every muscle, coloured by its activation (white at rest, red when contracting).

    Returns
    -------
    dict of str to pyvista.PolyData
        The mesh drawn for each muscle; writing into its ``activation`` array (and marking
        the array modified) recolours it without new actors.
    """
    activations = activations or {}
    return {m.name: add_muscle(plotter, m, activations.get(m.name, 0.0),
                               scalar_bar=scalar_bar and i == 0)
            for i, m in enumerate(face.muscles)}


def add_muscle(plotter: pv.Plotter, muscle, activation: float = 0.0, *,
               scalar_bar: bool = False) -> pv.PolyData:
    """Add one muscle (actor ``muscle:<name>``, replacing one of that name); returns its
    mesh (see :func:`add_muscles`).
    """
    mesh = muscle_mesh(muscle, activation)
    options = dict(scalars="activation", cmap="Reds", clim=(0.0, 1.0), **_shading(mesh),
                   name=f"muscle:{muscle.name}", render=False, show_scalar_bar=scalar_bar,
                   reset_camera=False, scalar_bar_args=field_bar_args("activation", nan=False)
                   if scalar_bar else None)
    plotter.add_mesh(mesh, **options)  # a tube has its own normals: a write is cheap
    _fit_bar(plotter, options, nan=False)
    return mesh


def replace_mesh(plotter: pv.Plotter, name: str, mesh: pv.PolyData) -> bool:
    """Show ``mesh`` in place of what actor ``name`` draws, keeping the actor and its
    mapper settings (much cheaper than ``add_mesh`` while dragging). ``mesh`` itself is
    drawn, so writing into its arrays later updates the view. Returns False, doing nothing,
    if there is no such actor.
    """
    actor = plotter.actors.get(name)
    if actor is None or getattr(actor, "mapper", None) is None:
        return False
    actor.mapper.dataset = mesh  # PyVista reconnects its scalars pipeline to it
    return True


def add_skull(plotter: pv.Plotter, face: FaceModel, *, attachments: bool = True):
    """Add the bone-coloured skull and, optionally, the muscles' attachment points."""
    if face.skull is None:
        raise ValueError("this face has no skull")
    actor = plotter.add_mesh(to_surface_polydata(face.skull), color=BONE,
                             smooth_shading=True, name="skull", render=False)
    if attachments:
        add_attachments(plotter, face)
    return actor


def attachment_points(face: FaceModel) -> np.ndarray:
    """``(k, 3)``: every muscle's attachment points (the point parameters its type declares
    on the skull, :meth:`~wrinkle_vis.core.muscle.Muscle.point_surfaces`), in muscle order.
    """
    pts = [np.asarray(getattr(m, p), float).reshape(-1, 3)
           for m in face.muscles for p, where in m.point_surfaces().items()
           if where == "skull"]
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def add_attachments(plotter: pv.Plotter, face: FaceModel) -> None:
    """Mark every muscle's attachment points (actor ``attachments``, replaced if there)."""
    pts = attachment_points(face)
    if not len(pts):
        plotter.remove_actor("attachments", render=False)
        return
    plotter.add_points(pts, color="#7a1f1f", point_size=9,
                       render_points_as_spheres=True, name="attachments", render=False,
                       reset_camera=False, pickable=False)


def set_camera(plotter: pv.Plotter, name: str, face: FaceModel) -> None:
    """Point the camera at the face from a named view (:data:`CAMERAS`).

    ``forehead`` and ``upper_face`` frame the face by its landmarks (nasion and outer eye
    corners) when it has them, whatever the scan's extent and unit.
    """
    if name not in CAMERAS:
        raise KeyError(f"unknown camera {name!r}; cameras: {', '.join(CAMERAS)}")
    direction, zoom = CAMERAS[name]
    d = np.asarray(direction) / np.linalg.norm(direction)
    if name in _LANDMARK_FRAMES and all(k in face.landmarks for k in _FRAME_MARKS):
        nasion, left, right = (np.asarray(face.landmarks[k]) for k in _FRAME_MARKS)
        span = float(np.linalg.norm(left - right))
        rise, height = _LANDMARK_FRAMES[name]
        center = nasion + np.array([0.0, rise * span, 0.0])
        distance = 0.5 * height * span / np.tan(np.radians(15.0))
        plotter.camera_position = [tuple(center + distance * d), tuple(center), (0.0, 1.0, 0.0)]
        plotter.camera.view_angle = 30.0
        plotter.reset_camera_clipping_range()
        return
    lo, hi = face.skin.bounds()
    center = 0.5 * (lo + hi)
    if name in _CAMERA_HEIGHTS:
        center = np.array([center[0], lo[1] + _CAMERA_HEIGHTS[name] * (hi[1] - lo[1]), hi[2]])
    distance = 2.6 * float(np.max(hi - lo))
    plotter.camera_position = [tuple(center + distance * d), tuple(center), (0.0, 1.0, 0.0)]
    plotter.reset_camera_clipping_range()
    plotter.camera.view_angle = 30.0  # zoom() narrows the current angle: start afresh
    plotter.camera.zoom(zoom)


def _check_layers(layers) -> None:
    """``ValueError`` naming the layers of ``layers`` not in :data:`LAYERS` (or none)."""
    unknown = [layer for layer in layers if layer not in LAYERS]
    if unknown or not layers:
        raise ValueError(f"unknown layer(s) {unknown}; choose from {', '.join(LAYERS)}")


def _add_layers(plotter: pv.Plotter, face: FaceModel, state: FaceState, field: str | None,
                muscle: str | None, layers) -> None:
    """Draw ``layers`` of ``state``: the skin coloured by ``field`` (translucent over the
    others), the muscles, the skull.
    """
    if "skin" in layers:
        add_skin(plotter, state, field, muscle,
                 opacity=0.35 if ("muscles" in layers or "skull" in layers) else 1.0)
    if "muscles" in layers:
        add_muscles(plotter, face, state.activations, scalar_bar="skin" not in layers)
    if "skull" in layers:
        add_skull(plotter, face)


def _scene_title(expression, field: str | None, muscle: str | None, layers) -> str:
    """``"surprise: W of frontalis_major_L, skull"``: the expression and what is drawn."""
    label = expression if isinstance(expression, str) else "custom"
    what = [f"{field}{'' if muscle is None else ' of ' + muscle}"] if (
        "skin" in layers and field) else []
    what += [layer for layer in layers if layer != "skin" or not field]
    return f"{label}: {', '.join(what)}"


def render_field(face: FaceModel, expression="surprise", field: str | None = "W",
                 muscle: str | None = None, *, layers=("skin",), camera: str = "front",
                 size=(800, 800), intensity: float = 1.0, filename=None, title=None,
                 theme=None, plotter: pv.Plotter | None = None, refine: bool = False,
                 refine_angle_deg: float | None = None,
                 refine_levels: int | None = None) -> np.ndarray:
    """Render a field of an expression off screen, with scalar bar and title, to a PNG.

    Parameters
    ----------
    face : FaceModel
        The face.
    expression : str, Expression or mapping
        What to evaluate (see :meth:`FaceModel.evaluate`).
    field : str or None
        A field of :data:`~wrinkle_vis.plotting.fields.FIELDS`; None for plain skin.
    muscle : str, optional
        Whose field; None for the total (``W`` only).
    layers : sequence of str
        Any of ``"skin"``, ``"muscles"`` (over a translucent skin when both), ``"skull"``.
    camera : str
        One of :data:`CAMERAS`.
    size : (int, int)
        Image size in pixels.
    filename : path, optional
        Where to write the PNG, atomically
        (:func:`~wrinkle_vis.plotting.writers.save_image`); checked before any work.
    plotter : pyvista.Plotter, optional
        Draw into this plotter (for image tests) instead of a new one; it is not closed.
    refine : bool
        Evaluate with adaptive refinement (:meth:`FaceModel.evaluate`).
    refine_angle_deg, refine_levels : optional
        Its bending threshold and most levels (None: the model's defaults).

    Returns
    -------
    (h, w, 3) uint8 ndarray
        The image.
    """
    _check_layers(layers)
    if filename is not None:
        check_target(filename, IMAGE_SUFFIXES)
    state = evaluate(face, expression, intensity, refine=refine,
                     refine_angle_deg=refine_angle_deg, refine_levels=refine_levels)
    own = plotter is None
    if own:
        plotter = pv.Plotter(off_screen=True, window_size=list(size), theme=theme)
    try:
        _add_layers(plotter, face, state, field, muscle, layers)
        plotter.add_title(title or _scene_title(expression, field, muscle, layers),
                          font_size=max(6, round(plotter.window_size[0] / 60)))
        set_camera(plotter, camera, face)
        image = plotter.screenshot(None, return_img=True)
    finally:
        if own:
            plotter.close()
    if filename is not None:
        save_image(image, filename)
    return image
