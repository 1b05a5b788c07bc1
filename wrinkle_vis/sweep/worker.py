"""One run of a sweep, as a Dask worker does it, with the caches a worker keeps for its life.

This module is importable (not ``__main__``), so the caches below live once per worker
process: the faces it has loaded (a few, least recently used first out), the crossing pairs
of their rest skins, and one off-screen plotter, made on the first image and reused for every
later one (a plotter made per task would cost a render window and leak memory,
``docs/sweeps.md``).

A run writes into a temporary folder beside its final one and renames it when everything
is written; ``run.json`` in it records the parameters, the seed, the outputs and the metrics.
"""

from __future__ import annotations

import io
import json
import math
import os
import shutil
import tempfile
import threading
import time
import traceback
from collections import OrderedDict
from pathlib import Path

import numpy as np

from wrinkle_vis.core.expressions import Expression
from wrinkle_vis.core.files import atomic_write_bytes, atomic_write_text
from wrinkle_vis.core.metrics import frame_metrics, rest_crossings

from .spec import ID_SKIN_MODEL

__all__ = ["RUNS", "FAILED", "cached_face", "evaluate_run", "execute", "execute_batch",
           "run_dir", "worker_plotter"]

#: The folder of the finished runs in a sweep's output folder, one sub-folder per run id.
RUNS = "runs"
#: The folder of the failed runs' records (``<id>.json``).
FAILED = "failed"
_FACES: OrderedDict = OrderedDict()
_FACE_CACHE_SIZE = 3
_REST_PAIRS: dict = {}
_PLOTTER: dict = {}
_PERFORMANCES: OrderedDict = OrderedDict()


def run_dir(out: str | os.PathLike, rid: str) -> Path:
    """The folder of run ``rid`` in the sweep folder ``out``."""
    return Path(out) / RUNS / rid


def cached_face(face: dict, layout_path: str | None = None):
    """The base face of a run's ``face`` parameters (its layout file read from
    ``layout_path``), loaded once per worker.
    """
    key = json.dumps([face, layout_path], sort_keys=True)
    hit = _FACES.get(key)
    if hit is not None:
        _FACES.move_to_end(key)
        return hit
    from wrinkle_vis.datasets import load_face

    if face["layout"] is not None:
        loaded = load_face(face["name"], face["n_triangles"], layout=layout_path)
    else:
        loaded = load_face(face["name"], face["n_triangles"])
    _FACES[key] = loaded
    while len(_FACES) > _FACE_CACHE_SIZE:
        old, _ = _FACES.popitem(last=False)
        _REST_PAIRS.pop(old, None)
    return loaded


def _rest_pairs(key: str, skin):
    if key not in _REST_PAIRS:
        _REST_PAIRS[key] = rest_crossings(skin)
    return _REST_PAIRS[key]


def _face_for(params: dict, layout_path: str | None):
    """The run's face: the base face with the varied parameters set."""
    face = cached_face(params["face"], layout_path)
    for muscle, changes in params["set"].items():
        face = face.with_muscle(face.muscle(muscle).replace(**changes))
    return face


def _performance(face, params: dict, track_path: str | None):
    """The run's recorded track through its face's mapping (read once per worker)."""
    from wrinkle_vis.core.tracks import default_mapping, performance, read_track

    expr = params["expression"]
    key = json.dumps([params["face"], expr], sort_keys=True)
    hit = _PERFORMANCES.get(key)
    if hit is None:
        if track_path is None:
            raise ValueError(f"run of track {expr['track']!r} without the track's path")
        track = read_track(track_path, expr["format"], expr["fps"])
        hit = performance(track, face.mapping or default_mapping(), face.muscle_names,
                          name=expr["name"])
        _PERFORMANCES[key] = hit
        while len(_PERFORMANCES) > _FACE_CACHE_SIZE:
            _PERFORMANCES.popitem(last=False)
    _PERFORMANCES.move_to_end(key)
    return hit


def _activations(face, params: dict, track_path: str | None = None) -> dict[str, float]:
    expr = params["expression"]
    if isinstance(expr, dict) and "track" in expr:
        return _performance(face, params, track_path).at(params["time_s"], params["intensity"])
    if isinstance(expr, str):
        expr = face.expressions[expr]
    else:
        expr = Expression(expr["name"], expr["activations"])
    k = params["intensity"]
    if params["time_s"] is None:
        return face.activations_for(expr, k)
    return face.activations_for(expr.at(params["time_s"], k))


def evaluate_run(params: dict, prominence: float = 0.1, layout_path: str | None = None,
                 track_path: str | None = None):
    """``(face, state, metrics)`` of one run's parameters (see :class:`~.spec.Run`).

    Parameters
    ----------
    params : dict
        The run's parameters.
    prominence : float
        The least crest or furrow counted (:func:`~wrinkle_vis.core.metrics.frame_metrics`).
    layout_path : str, optional
        Where the face's layout file lies (:attr:`~.spec.Run.layout_path`).
    track_path : str, optional
        Where a recorded track lies (:attr:`~.spec.Run.track_path`); the run plays it at
        ``time_s`` through the face's mapping.

    Returns
    -------
    face : FaceModel
        The face with the run's muscle parameters.
    state : FaceState
        The evaluated frame.
    metrics : dict
        :func:`~wrinkle_vis.core.metrics.frame_metrics` of the frame.
    """
    face = _face_for(params, layout_path)
    acts = _activations(face, params, track_path)
    start = time.perf_counter()
    state = face.evaluate(acts, refine=params["refine"],
                          skin=params.get("skin_model", ID_SKIN_MODEL))
    seconds = time.perf_counter() - start
    pairs = None
    if state.face.skin is face.skin:
        pairs = _rest_pairs(json.dumps([params["face"], layout_path], sort_keys=True),
                            face.skin)
    metrics = frame_metrics(state, prominence=prominence,
                            rest_pairs=pairs, time_s=params["time_s"], frame_seconds=seconds)
    return face, state, metrics


def worker_plotter(size):
    """The worker's one off-screen plotter, resized to ``size`` (made on first use).

    One per thread that renders (a worker has one thread): an OpenGL context is current
    in the thread that made it, and rendering from another thread fails.
    """
    import pyvista as pv

    key = threading.get_ident()
    plotter = _PLOTTER.get(key)
    if plotter is None or plotter._closed:
        from wrinkle_vis.plotting import testing_theme

        theme = testing_theme()
        theme.window_size = list(size)
        plotter = pv.Plotter(off_screen=True, window_size=list(size), theme=theme)
        plotter.show(auto_close=False)  # else render() does nothing and images go stale
        _PLOTTER[key] = plotter
    if list(plotter.window_size) != list(size):
        plotter.window_size = list(size)
    return plotter


def close_worker_plotter() -> None:
    """Close the worker's plotters (at the end of a serial loop; tests)."""
    while _PLOTTER:
        _, plotter = _PLOTTER.popitem()
        plotter.close()


def _images(state, face, options: dict, folder: Path) -> list[str]:
    from wrinkle_vis.plotting import add_raking_light, add_skin, clear_scene, set_camera
    from wrinkle_vis.plotting.writers import save_image

    plotter = worker_plotter(options["size"])
    names = []
    for field in options["fields"]:
        for camera in options["cameras"]:
            clear_scene(plotter)
            add_skin(plotter, state, None if field == "none" else field, scalar_bar=False)
            if options["raking_light"]:
                add_raking_light(plotter)
            set_camera(plotter, camera, face)
            plotter.render()  # screenshot() itself renders only the first image
            image = plotter.screenshot(None, return_img=True)
            name = f"{field}_{camera}.png"
            save_image(image, folder / name)
            names.append(name)
    clear_scene(plotter)
    return names


def _meshes(state, face, formats: list, folder: Path, rid: str) -> list[str]:
    names = []
    if "vtp" in formats or "ply" in formats:
        from wrinkle_vis.plotting import to_polydata
        from wrinkle_vis.plotting.writers import save_mesh

        mesh = to_polydata(state)
        for fmt in ("vtp", "ply"):
            if fmt in formats:
                save_mesh(mesh, folder / f"skin.{fmt}")
                names.append(f"skin.{fmt}")
    if "glb" in formats:
        from wrinkle_vis.plotting.exchange import save_gltf

        framed = face.with_expressions({rid: Expression(rid, {
            m: a for m, a in state.activations.items() if a > 0})})
        save_gltf(framed, folder / "skin.glb", [rid])
        names.append("skin.glb")
    return names


def _arrays(state, names: list, path: Path) -> None:
    out = {}
    active = [m for m, a in state.activations.items() if a > 0]
    for name in names:
        if name in ("lambda", "gamma", "l", "eps", "At", "A", "H", "w"):
            for m in active:
                out[f"{name}:{m}"] = np.asarray(state.fields[m][name])
        elif name == "triangles":
            out[name] = np.asarray(state.triangles)
        else:
            out[name] = np.asarray(getattr(state, name))
    buffer = io.BytesIO()
    np.savez(buffer, **out)
    atomic_write_bytes(path, buffer.getvalue())


def _plain(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, np.generic):
        return _plain(value.item())
    return value


def execute(task: dict) -> dict:
    """Run one task of a sweep and write its folder; returns its record.

    Parameters
    ----------
    task : dict
        ``id``, ``seed``, ``params``, ``columns`` and ``layout_path`` (:class:`~.spec.Run`),
        ``outputs``, ``outputs_key`` and ``out`` (the sweep folder).

    Returns
    -------
    dict
        The record written as ``run.json``: ``id``, ``seed``, ``status`` (``"done"``, or
        ``"failed"`` with ``error`` one line, the record then written to
        ``failed/<id>.json`` instead and the run folder left absent), ``columns``,
        ``metrics``, ``files`` and ``outputs_key``.
    """
    out = Path(task["out"])
    final = run_dir(out, task["id"])
    record = {"id": task["id"], "seed": task["seed"], "params": task["params"],
              "columns": task["columns"], "outputs_key": task["outputs_key"]}
    tmp = Path(tempfile.mkdtemp(prefix=f".tmp-{task['id']}-", dir=final.parent))
    try:
        face, state, metrics = evaluate_run(task["params"], task["outputs"]["prominence"],
                                             task.get("layout_path"), task.get("track_path"))
        outputs = task["outputs"]
        files = []
        if outputs["arrays"]:
            _arrays(state, outputs["arrays"], tmp / "arrays.npz")
            files.append("arrays.npz")
        if outputs["images"] is not None:
            files += _images(state, face, outputs["images"], tmp)
        files += _meshes(state, face, outputs["meshes"], tmp, task["id"])
        record.update(status="done", error=None, files=files,
                      metrics={k: _plain(v) for k, v in metrics.items()})
        atomic_write_text(tmp / "run.json", json.dumps(record, indent=1, allow_nan=False))
        _replace(tmp, final)
        failed = out / FAILED / f"{task['id']}.json"
        if failed.exists():
            failed.unlink()
        return record
    except Exception as exc:  # recorded, and the sweep goes on
        shutil.rmtree(tmp, ignore_errors=True)
        message = " ".join(f"{type(exc).__name__}: {exc}".split())
        record.update(status="failed", error=message, files=[], metrics={},
                      traceback=traceback.format_exc())
        (out / FAILED).mkdir(exist_ok=True)
        atomic_write_text(out / FAILED / f"{task['id']}.json",
                          json.dumps(record, indent=1, allow_nan=False))
        return record


def execute_batch(shared: dict, runs: list[dict]) -> list[dict]:
    """Run several runs of a sweep one after the other (one Dask task); their records.

    Parameters
    ----------
    shared : dict
        What the runs share: ``outputs``, ``outputs_key`` and ``out``.
    runs : list of dict
        Per run ``id``, ``seed``, ``params``, ``columns`` and ``layout_path``.

    Returns
    -------
    list of dict
        :func:`execute`'s record of each run, in order (a failing run is recorded and the
        next one runs).
    """
    return [execute({**shared, **run}) for run in runs]


def _replace(tmp: Path, final: Path) -> None:
    """Rename the finished folder ``tmp`` to ``final`` (an older ``final``, written with
    other outputs, is moved aside first and removed).
    """
    os.chmod(tmp, 0o777 & ~_umask())
    if final.exists():
        old = Path(tempfile.mkdtemp(prefix=f".old-{final.name}-", dir=final.parent))
        os.rename(final, old / final.name)
        os.rename(tmp, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.rename(tmp, final)


def _umask() -> int:
    from wrinkle_vis.core.files import umask

    return umask()
