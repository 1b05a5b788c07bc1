"""Data sets: the built-in anatomy-based face, scans and layouts (``wrinkle_vis.datasets``)."""

from .face import (
    BUILTIN_LAYOUT,
    build_skin,
    build_skull,
    builtin_expressions,
    builtin_landmarks,
    builtin_layout,
    builtin_muscles,
    load_face,
)
from .scans import LANDMARKS, offset_skull, read_surface, transfer_layout

__all__ = ["BUILTIN_LAYOUT", "LANDMARKS", "build_skin", "build_skull", "builtin_expressions",
           "builtin_landmarks", "builtin_layout", "builtin_muscles", "load_face",
           "offset_skull", "read_surface", "transfer_layout"]
