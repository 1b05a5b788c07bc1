"""An expression's ramp as a stream of frames, rendered off screen (no Qt).

:func:`frame_times` plans the frames (and refuses absurd counts before any work);
:func:`animation_frames` renders them one at a time into one plotter, so a caller can hand
them to a streaming writer (:func:`~wrinkle_vis.plotting.writers.save_animation`) and
memory stays flat however long the animation is.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pyvista as pv

from ..core.face import FaceModel
from ..core.units import face_unit
from .fields import field_info, field_range
from .scenes import LAYERS, add_muscles, add_skin, add_skull, clear_scene, evaluate, set_camera

__all__ = ["MAX_FRAMES", "TooManyFramesError", "animation_frames", "frame_times"]

#: The most frames :func:`frame_times` plans.
MAX_FRAMES = 10_000


class TooManyFramesError(ValueError):
    """An animation of more than :data:`MAX_FRAMES` frames; says how to make it shorter."""


def frame_times(expression, fps: float, max_frames: int = MAX_FRAMES) -> np.ndarray:
    """``(k,)``: the times in seconds of an expression's frames at ``fps``, both ends of its
    onset-hold-release envelope included.

    Raises
    ------
    ValueError
        If ``fps`` is not positive.
    TooManyFramesError
        If there would be more than ``max_frames`` frames, naming the duration and the way
        out (a lower fps, a shorter hold).
    """
    fps = float(fps)
    if not fps > 0 or not np.isfinite(fps):
        raise ValueError(f"fps = {fps:g} must be a positive number")
    duration = float(expression.duration_s)
    n = int(np.floor(duration * fps + 1e-9)) + 1
    if n > max_frames:
        fastest = int(np.floor((max_frames - 1) / duration))  # whole fps that fit
        way_out = (f"lower the fps to {fastest} or less, or shorten the expression's hold_s "
                   "in the layout" if fastest >= 1 else
                   "shorten the expression's hold_s in the layout (even 1 fps makes "
                   f"{int(np.floor(duration)) + 1:,} frames)")
        raise TooManyFramesError(
            f"{expression.name!r} lasts {duration:g} s (onset {expression.onset_s:g}, hold "
            f"{expression.hold_s:g}, release {expression.release_s:g}), {n:,} frames at "
            f"{fps:g} fps, more than {max_frames:,}; {way_out}")
    return np.arange(n) / fps


def animation_frames(face: FaceModel, expression, times, *, field: str | None = "W",
                     muscle: str | None = None, layers=("skin",), camera: str = "front",
                     size=(480, 480), intensity: float = 1.0, label: str | None = None,
                     theme=None, refine: bool = False, refine_angle_deg: float | None = None,
                     refine_levels: int | None = None) -> Iterator[np.ndarray]:
    """Render ``expression`` (an :class:`~wrinkle_vis.core.expressions.Expression`) at each
    of ``times``, one ``(h, w, 3) uint8`` frame at a time.

    The layers are drawn as :func:`~wrinkle_vis.plotting.render_field` draws them; the colour
    range of ``field`` is fixed over the whole ramp (the range at the peak), so the ramp is
    visible. One off-screen plotter is used and closed when the generator ends or is closed.
    ``refine`` evaluates every frame with adaptive refinement, with the bending threshold
    and most levels given (None: the model's defaults, :meth:`FaceModel.evaluate`). On a
    face whose skin model is the physical one the frames are simulated
    (:meth:`FaceModel.expression_states`).
    """
    unknown = [layer for layer in layers if layer not in LAYERS]
    if unknown or not layers:
        raise ValueError(f"unknown layer(s) {unknown}; choose from {', '.join(LAYERS)}")
    label = label or expression.name
    info = field_info(field) if field else None
    options = {"refine": refine, "refine_angle_deg": refine_angle_deg,
               "refine_levels": refine_levels}
    clim = None
    if info is not None and "skin" in layers:
        peak = evaluate(face, expression, intensity, **options)
        clim = field_range(info, peak.W if muscle is None else peak.fields[muscle][field])
    translucent = "muscles" in layers or "skull" in layers
    plotter = pv.Plotter(off_screen=True, window_size=[int(size[0]), int(size[1])],
                         theme=theme)
    opts = {k: v for k, v in options.items() if v is not None}
    states = face.expression_states(expression, times, intensity, **opts)
    try:
        for t, state in zip(times, states, strict=True):
            clear_scene(plotter)
            if "skin" in layers:
                add_skin(plotter, state, field, muscle, opacity=0.35 if translucent else 1.0)
                if clim is not None:
                    plotter.update_scalar_bar_range(clim, name=info.title(muscle, face_unit(face)))
            if "muscles" in layers:
                add_muscles(plotter, face, state.activations, scalar_bar="skin" not in layers)
            if "skull" in layers:
                add_skull(plotter, face)
            plotter.add_title(f"{label}  t = {float(t):.2f} s",
                              font_size=max(6, round(plotter.window_size[0] / 48)))
            set_camera(plotter, camera, face)
            yield plotter.screenshot(return_img=True)
    finally:
        plotter.close()
