"""wrinkle-vis: the muscle-driven facial wrinkle model of Zhang, Sim and Tan, visualized.

The model lives in :mod:`wrinkle_vis.core` (numpy and scipy only) and is re-exported here.
``wrinkle_vis.datasets`` (the built-in face, mesh and layout loaders) is imported on first
use, so ``import wrinkle_vis`` stays light.
"""

from __future__ import annotations

import importlib

from . import _plot  # noqa: F401  (binds FaceModel.plot, FaceState.plot, .to_polydata)
from .core import *  # noqa: F403
from .core import __all__ as _core_all

__version__ = "0.1.0"
__all__ = [*_core_all, "__version__"]

_LAZY = {"datasets", "plotting", "sweep", "widgets"}  # wv.sweep(spec, out): a callable module


def __getattr__(name: str):
    if name in _LAZY:
        module = importlib.import_module(f"wrinkle_vis.{name}")
        globals()[name] = module
        return module
    raise AttributeError(f"module 'wrinkle_vis' has no attribute {name!r}")
