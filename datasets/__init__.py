"""Data sets: the built-in anatomy-based face (installed as ``wrinkle_vis.datasets``)."""

from .face import build_skin, build_skull, builtin_expressions, builtin_muscles, load_face

__all__ = ["build_skin", "build_skull", "builtin_expressions", "builtin_muscles", "load_face"]
