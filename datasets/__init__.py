"""Data sets: the built-in anatomy-based face, scans and layouts (``wrinkle_vis.datasets``)."""

from .face import (
    BUILTIN_LAYOUT,
    FACES,
    build_skin,
    build_skull,
    builtin_expressions,
    builtin_landmarks,
    builtin_layout,
    builtin_muscles,
    load_face,
)
from .scans import LANDMARKS, read_landmarks, read_surface, scan_layout, transfer_layout
from .skull import scan_skull

__all__ = ["BUILTIN_LAYOUT", "FACES", "LANDMARKS", "build_skin", "build_skull",
           "builtin_expressions", "builtin_landmarks", "builtin_layout", "builtin_muscles",
           "load_face", "read_landmarks", "read_surface", "scan_layout", "scan_skull",
           "transfer_layout"]
