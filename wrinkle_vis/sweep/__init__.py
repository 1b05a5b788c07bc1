"""Parameter studies on Dask: ``wv.sweep(spec, out)`` and ``wrinkle-vis sweep SPEC -o OUT``.

A layer over the core, the data sets and the plotting (no Qt): a spec (``docs/sweeps.md``)
names faces, expressions and the parameters to vary; every run is named by a hash of its
parameters, writes its folder atomically and is skipped when a sweep is started again; the
sweep ends with one Parquet table of every parameter and metric
(:mod:`wrinkle_vis.core.metrics`).

The module itself is callable, so that ``wv.sweep(spec, out)`` works whether or not
``wrinkle_vis.sweep`` was imported before (importing a submodule makes it the package's
attribute of that name): calling it calls :func:`~wrinkle_vis.sweep.runner.sweep`.
"""

from __future__ import annotations

import sys
import types

from .runner import TABLE, SweepError, sweep, table_frame, write_table
from .spec import Run, SweepSpec, SweepSpecError, load_spec, run_id

__all__ = ["TABLE", "Run", "SweepError", "SweepSpec", "SweepSpecError", "load_spec", "run_id",
           "sweep", "table_frame", "write_table"]


class _CallableModule(types.ModuleType):
    """The ``wrinkle_vis.sweep`` module, callable as :func:`sweep`."""

    def __call__(self, spec, out, client=None, **kwargs):
        return sweep(spec, out, client, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
