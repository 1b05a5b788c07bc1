"""PyVista adapters and off-screen rendering (no Qt)."""

from .fields import FIELDS, NAN_COLOR, FieldInfo, field_info, field_range
from .figures import figure_expressions, figure_refinement
from .glyphs import generic_glyph, glyph_factory, register_glyph
from .notebook import (
    FaceExplorer,
    default_backend,
    has_display,
    in_notebook,
    notebook_plotter,
    plot_face,
    plot_state,
)
from .offscreen import prefer_egl_when_headless
from .polydata import field_array_name, to_polydata, to_surface_polydata
from .scenes import (
    BONE,
    CAMERAS,
    LAYERS,
    SKIN,
    add_attachments,
    add_muscle,
    add_muscles,
    add_raking_light,
    add_skin,
    add_skin_mesh,
    add_skull,
    attachment_points,
    clear_scene,
    muscle_mesh,
    remove_raking_light,
    render_field,
    replace_mesh,
    set_camera,
    testing_theme,
    to_multiblock,
)

__all__ = ["BONE", "CAMERAS", "FIELDS", "LAYERS", "NAN_COLOR", "SKIN", "FaceExplorer", "FieldInfo",
           "add_attachments", "add_muscle", "add_muscles", "add_raking_light",
           "remove_raking_light", "add_skin",
           "add_skin_mesh", "add_skull", "attachment_points", "clear_scene", "field_array_name",
           "field_info", "field_range", "figure_expressions", "figure_refinement",
           "generic_glyph", "glyph_factory", "register_glyph", "muscle_mesh", "render_field",
           "replace_mesh", "set_camera", "testing_theme", "to_multiblock", "to_polydata",
           "to_surface_polydata", "default_backend", "has_display", "in_notebook",
           "notebook_plotter", "plot_face", "plot_state"]

prefer_egl_when_headless()  # importing makes no render window; using it may
