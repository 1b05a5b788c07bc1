"""The paper's figures, off screen: plain skin under a raking light.

:func:`figure_expressions` is Fig. 9 (each expression without and with wrinkles),
:func:`figure_dynamics` is Fig. 10 (wrinkles forming on the simulated skin after an
activation step, with their times), :func:`figure_refinement` is Fig. 11 (the adaptively
refined mesh over the forehead during surprise). Each returns the image and writes it when
given a file name; the ``wrinkle-vis figure`` command calls them.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from ..core.face import FaceModel
from .scenes import add_raking_light, add_skin, evaluate, set_camera
from .writers import IMAGE_SUFFIXES, check_target, save_image

__all__ = ["EDGE_COLOR", "PANEL_SIZE", "figure_dynamics", "figure_expressions",
           "figure_refinement", "wrinkle_camera"]

#: Pixel size of one panel of :func:`figure_expressions` when no size is given.
PANEL_SIZE = (440, 400)
#: Colour of the mesh edges drawn over the skin in :func:`figure_refinement`.
EDGE_COLOR = "#6b4330"


def _title(plotter: pv.Plotter, text: str, width: int) -> None:
    """A title at the top of the active renderer, on a translucent white band."""
    size = max(6, round(min(width / 48, 0.75 * width / max(len(text), 1))))
    actor = plotter.add_text(text, position="upper_edge", font_size=size, color="black",
                             name="title")
    prop = actor.GetTextProperty()
    prop.SetBackgroundColor(1.0, 1.0, 1.0)
    prop.SetBackgroundOpacity(0.75)


#: The direction fig. 9's framed camera looks from (as the ``upper_face`` camera's).
FRAME_DIRECTION = (0.0, 0.1, 1.0)


def wrinkle_camera(states, aspect: float = 1.0, *, direction=FRAME_DIRECTION,
                   margin: float = 0.15, view_angle_deg: float = 30.0):
    r"""A camera that sees every vertex the frames ``states`` wrinkle (:math:`W \ne 0`),
    whichever muscles made them: forehead furrows and the mouth's alike.

    Parameters
    ----------
    states : sequence of FaceState
        The frames (one camera for all).
    aspect : float
        Width over height of the view.
    direction : (3,) float
        From the wrinkles' centre towards the eye.
    margin : float
        Room around the wrinkles, a fraction of their extent.
    view_angle_deg : float
        The camera's vertical view angle (VTK's default, 30).

    Returns
    -------
    list or None
        ``[position, focal point, view up]``; None when nothing is wrinkled.

    Notes
    -----
    With :math:`d` the unit direction, :math:`u` the unit +y made orthogonal to it and
    :math:`r = u \times d`, the wrinkled points :math:`p` about their box's centre
    :math:`c` span :math:`h = \max |(p - c) \cdot u|` and :math:`w = \max |(p - c) \cdot r|`.
    The eye is at :math:`c + D d` with
    :math:`D = (1 + m) \max(h, w / a, h_{min}) / \tan(\theta / 2) + \max (p - c) \cdot d`,
    so every point is inside the view, nearer ones (the last term) included;
    :math:`h_{min}` is a tenth of the skin's height, so that a few wrinkled vertices are
    not blown up.
    """
    wrinkled = [np.asarray(s.points)[np.asarray(s.W) != 0] for s in states]
    points = np.vstack([p for p in wrinkled if len(p)] or [np.zeros((0, 3))])
    if not len(points):
        return None
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    up = np.array([0.0, 1.0, 0.0]) - d[1] * d
    up /= np.linalg.norm(up)
    right = np.cross(up, d)
    center = 0.5 * (points.min(axis=0) + points.max(axis=0))
    rel = points - center
    lo, hi = states[0].face.skin.bounds()
    half = max(float(np.abs(rel @ up).max()), float(np.abs(rel @ right).max()) / aspect,
               0.1 * float(hi[1] - lo[1]))
    distance = ((1.0 + margin) * half / np.tan(np.radians(0.5 * view_angle_deg))
                + max(float((rel @ d).max()), 0.0))
    return [tuple(center + distance * d), tuple(center), tuple(up)]


def _label(expression) -> str:
    return expression if isinstance(expression, str) else "custom"


def figure_expressions(face: FaceModel, expressions=("surprise", "frown", "fear"),
                       filename=None, *, size=None, intensity: float = 1.0,
                       refine: bool = False, camera: str | None = None,
                       elevation_deg: float = 20.0, azimuth_deg: float = 35.0,
                       theme=None, refine_angle_deg: float | None = None,
                       refine_levels: int | None = None) -> np.ndarray:
    """The paper's Fig. 9: each expression without and with wrinkles, side by side.

    One row per expression. The left panel is the skin the muscles moved
    (``state.deformed_points``: no wrinkle displacement :math:`W`), the right one the final
    skin (``state.points``). Plain, matte skin under :func:`add_raking_light`, every panel
    with the same camera and lights.

    Parameters
    ----------
    face : FaceModel
        The face.
    expressions : sequence of (str, Expression or mapping)
        What to evaluate, one row each (see :meth:`FaceModel.evaluate`).
    filename : path, optional
        Where to write the PNG, atomically
        (:func:`~wrinkle_vis.plotting.writers.save_image`); checked before any work.
    size : (int, int), optional
        Image size in pixels; default :data:`PANEL_SIZE` per panel.
    intensity : float
        Scales every activation, in ``[0, 1]``.
    refine : bool
        Evaluate with adaptive refinement (both panels show the refined mesh).
    camera : str, optional
        One of :data:`~wrinkle_vis.plotting.CAMERAS`; default: framed on every wrinkle of
        the expressions (:func:`wrinkle_camera`: the forehead for surprise, the mouth for
        a smile), or ``upper_face`` when there is none.
    refine_angle_deg, refine_levels : optional
        The refinement's bending threshold and most levels (None: the model's defaults,
        :meth:`FaceModel.evaluate`).
    elevation_deg, azimuth_deg : float
        The raking light (see :func:`add_raking_light`).
    theme : pyvista theme, optional
        For image tests.

    Returns
    -------
    (h, w, 3) uint8 ndarray
        The image.
    """
    expressions = list(expressions)
    if not expressions:
        raise ValueError("name at least one expression")
    if filename is not None:
        check_target(filename, IMAGE_SUFFIXES)
    states = [evaluate(face, e, intensity, refine=refine, refine_angle_deg=refine_angle_deg,
                       refine_levels=refine_levels) for e in expressions]
    image = _expression_rows(face, expressions, states, size, camera,
                             (elevation_deg, azimuth_deg), theme)
    if filename is not None:
        save_image(image, filename)
    return image


def _expression_rows(face: FaceModel, expressions: list, states: list, size, camera,
                     light: tuple[float, float], theme) -> np.ndarray:
    """:func:`figure_expressions`' image: a row per expression and its frame ``states``,
    without and with wrinkles, under the raking ``light`` (elevation, azimuth).
    """
    width, height = size or (2 * PANEL_SIZE[0], len(expressions) * PANEL_SIZE[1])
    framed = None if camera is not None else wrinkle_camera(
        states, (width / 2) / (height / len(expressions)))
    plotter = pv.Plotter(off_screen=True, shape=(len(expressions), 2), border=False,
                         window_size=[int(width), int(height)], theme=theme)
    try:
        plotter.set_background("white")
        for row, (expression, state) in enumerate(zip(expressions, states, strict=True)):
            for col, (what, points) in enumerate((("without wrinkles", state.deformed_points),
                                                  ("with wrinkles", state.points))):
                plotter.subplot(row, col)
                add_skin(plotter, state, None, points=points)
                add_raking_light(plotter, *light)
                _title(plotter, f"{_label(expression)}: {what}", width // 2)
                _aim(plotter, face, camera, framed)
        return plotter.screenshot(None, return_img=True)
    finally:
        plotter.close()


def _aim(plotter: pv.Plotter, face: FaceModel, camera: str | None, framed) -> None:
    """The subplot's camera: ``framed`` (a camera position) when given, else ``camera``
    (default ``upper_face``).
    """
    if framed is None:
        set_camera(plotter, camera or "upper_face", face)
    else:
        plotter.camera_position = framed
        plotter.camera.view_angle = 30.0
        plotter.reset_camera_clipping_range()


def figure_refinement(face: FaceModel, filename=None, *, expression="surprise",
                      size=(800, 800), intensity: float = 1.0, camera: str = "forehead",
                      elevation_deg: float = 20.0, azimuth_deg: float = 35.0,
                      theme=None, refine_angle_deg: float | None = None,
                      refine_levels: int | None = None) -> np.ndarray:
    """The paper's Fig. 11: the adaptively refined mesh over the shaded forehead.

    ``expression`` is evaluated with ``refine=True``; the refined skin (``state.face.skin``
    at ``state.points``) is drawn as plain skin under :func:`add_raking_light` with its
    edges in :data:`EDGE_COLOR`. The title gives the triangle counts before and after.

    Parameters
    ----------
    face : FaceModel
        The face.
    filename : path, optional
        Where to write the PNG, atomically; checked before any work.
    expression : str, Expression or mapping
        What to evaluate (the paper shows surprise).
    size : (int, int)
        Image size in pixels.
    intensity : float
        Scales every activation, in ``[0, 1]``.
    camera : str
        One of :data:`~wrinkle_vis.plotting.CAMERAS`.
    elevation_deg, azimuth_deg : float
        The raking light (see :func:`add_raking_light`).
    theme : pyvista theme, optional
        For image tests.
    refine_angle_deg, refine_levels : optional
        The refinement's bending threshold and most levels (None: the model's defaults,
        :meth:`FaceModel.evaluate`).

    Returns
    -------
    (h, w, 3) uint8 ndarray
        The image.
    """
    if filename is not None:
        check_target(filename, IMAGE_SUFFIXES)
    state = evaluate(face, expression, intensity, refine=True,
                     refine_angle_deg=refine_angle_deg, refine_levels=refine_levels)
    width, height = size
    plotter = pv.Plotter(off_screen=True, window_size=[int(width), int(height)], theme=theme)
    try:
        plotter.set_background("white")
        actor = add_skin(plotter, state, None, show_edges=True, edge_color=EDGE_COLOR)
        actor.prop.edge_opacity = 0.6  # the shading stays readable under dense edges
        add_raking_light(plotter, elevation_deg, azimuth_deg)
        _title(plotter, f"{_label(expression)}, refined: {state.face.skin.n_triangles:,} "
                        f"triangles (from {face.skin.n_triangles:,})", width)
        set_camera(plotter, camera, face)
        image = plotter.screenshot(None, return_img=True)
    finally:
        plotter.close()
    if filename is not None:
        save_image(image, filename)
    return image


def simulated_snapshots(face: FaceModel, expression, times, intensity: float = 1.0) -> list:
    """The physical skin's states at ``times`` (seconds, ascending) after a step to
    ``expression`` (scaled by ``intensity``) at t = 0, stepping at the material's time step
    and landing on each time.
    """
    acts = face.activations_for(expression, intensity)
    sim = face.simulator(acts)
    out = []
    for t in sorted(float(t) for t in times):
        states = list(sim.run(t - sim.time))
        out.append(states[-1] if states else sim.state())
    return out


def figure_dynamics(face: FaceModel, expression="surprise", times=(0.033, 0.067, 0.1, 0.2, 0.5),
                    filename=None, *, size=None, intensity: float = 1.0,
                    camera: str = "forehead", elevation_deg: float = 20.0,
                    azimuth_deg: float = 35.0, theme=None) -> np.ndarray:
    """The paper's Fig. 10: wrinkles forming dynamically, one panel per simulated time.

    The face's physically based skin (:meth:`FaceModel.simulator`) starts at rest and the
    muscles are switched to ``expression`` at t = 0; each panel shows the final skin at one
    of ``times`` (seconds) with its time, plain skin under :func:`add_raking_light`.

    Returns
    -------
    (h, w, 3) uint8 ndarray
        The image (also written to ``filename`` when given).
    """
    times = list(times)
    if not times:
        raise ValueError("name at least one time")
    if filename is not None:
        check_target(filename, IMAGE_SUFFIXES)
    states = simulated_snapshots(face, expression, times, intensity)
    width, height = size or (len(times) * 320, 340)
    plotter = pv.Plotter(off_screen=True, shape=(1, len(times)), border=False,
                         window_size=[int(width), int(height)], theme=theme)
    try:
        plotter.set_background("white")
        for col, state in enumerate(states):
            plotter.subplot(0, col)
            add_skin(plotter, state, None)
            add_raking_light(plotter, elevation_deg, azimuth_deg)
            _title(plotter, f"{_label(expression)}: t = {1e3 * state.time:.0f} ms",
                   width // len(times))
            set_camera(plotter, camera, face)
        image = plotter.screenshot(None, return_img=True)
    finally:
        plotter.close()
    if filename is not None:
        save_image(image, filename)
    return image
