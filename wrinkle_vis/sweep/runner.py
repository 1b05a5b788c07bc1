"""Run a sweep on Dask: local worker processes by default, or an existing cluster.

:func:`sweep` checks the spec, skips the runs whose folders are complete, submits the rest,
shows a progress bar and gathers one Parquet table (:func:`write_table`). Ctrl+C cancels
what is queued and shuts down a cluster it started; the finished runs stay, and the same
call resumes.
"""

from __future__ import annotations

import io
import json
import logging
import os
import shutil
import sys
from collections.abc import Mapping
from pathlib import Path

from wrinkle_vis.core.files import atomic_write_bytes, atomic_write_text
from wrinkle_vis.core.metrics import METRICS

from .spec import Run, SweepSpec, load_spec
from .worker import FAILED, RUNS, execute_batch, run_dir

__all__ = ["LOCAL_WORKER_CONFIG", "MAX_BATCH", "TABLE", "SweepError", "batch_sizes",
           "finished_records", "local_cluster", "sweep", "table_frame", "write_table"]

#: The table's file name in the sweep folder.
TABLE = "results.parquet"
#: How long to wait for a scheduler to answer, seconds.
CONNECT_TIMEOUT_S = 10.0
#: At most this many runs in one Dask task (:func:`batch_sizes`).
MAX_BATCH = 8
#: A batch is at most the runs left over this many times the workers' threads.
BATCH_SPREAD = 4


class SweepError(RuntimeError):
    """A sweep that cannot start (an unreachable scheduler, an unusable output folder)."""


def sweep(spec, out, client=None, *, scheduler: str | None = None, workers: int | None = None,
          progress: bool = True, connect_timeout_s: float = CONNECT_TIMEOUT_S):
    """Run every run of a sweep spec that has not finished, then write its table.

    Parameters
    ----------
    spec : path, mapping or SweepSpec
        A ``.toml`` or ``.json`` spec file (``docs/sweeps.md``), its contents as a mapping,
        or a spec from :func:`~wrinkle_vis.sweep.load_spec`. Checked whole before anything
        runs.
    out : path
        The sweep folder: ``runs/<id>/`` per finished run (``run.json``, and the images,
        meshes and ``arrays.npz`` the spec asks for), ``failed/<id>.json`` per failed run,
        ``sweep.json`` (the spec) and ``results.parquet`` (the table).
    client : distributed.Client, optional
        Run on this client's cluster (it is left open).
    scheduler : str, optional
        Or the address of a running scheduler, ``tcp://HOST:8786``.
    workers : int, optional
        Without either: how many local worker processes to start (default: the CPUs this
        process may use). They are spawned, never forked, one thread each.
    progress : bool, default True
        Show a progress bar (tqdm, on standard error).
    connect_timeout_s : float
        How long to wait for ``scheduler``.

    Returns
    -------
    pandas.DataFrame
        The table (:func:`table_frame`): one row per run, sorted by run id.

    Raises
    ------
    SweepSpecError
        A bad spec, before anything runs.
    SweepError
        An unreachable scheduler or an unusable output folder, before anything runs.
    KeyboardInterrupt
        After Ctrl+C, once the queued runs are cancelled (finished runs stay; call again
        to resume).
    """
    spec = load_spec(spec)
    if client is not None and scheduler is not None:
        raise SweepError("give a client or a scheduler address, not both")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise SweepError(f"workers = {workers!r}; give a number of worker processes >= 1")
    runs = _unique(spec.runs())
    out = _prepare(Path(out), spec)
    records = finished_records(out, runs, spec.outputs_key())
    pending = [r for r in runs if r.id not in records]
    if pending:
        records.update(_run_all(spec, out, pending, client, scheduler, workers, progress,
                                connect_timeout_s))
    table = table_frame(runs, records)
    write_table(table, out / TABLE)
    return table


def _unique(runs: list[Run]) -> list[Run]:
    seen, out = set(), []
    for r in runs:
        if r.id not in seen:
            seen.add(r.id)
            out.append(r)
    return out


def _prepare(out: Path, spec: SweepSpec) -> Path:
    """Make the sweep folder, write ``sweep.json`` and drop what a killed sweep left."""
    if out.exists() and not out.is_dir():
        raise SweepError(f"{out}: is a file; give a folder for the sweep's outputs")
    try:
        (out / RUNS).mkdir(parents=True, exist_ok=True)
        (out / FAILED).mkdir(exist_ok=True)
        atomic_write_text(out / "sweep.json", json.dumps(
            {"name": spec.name, "source": spec.source, "spec": spec.raw}, indent=1,
            default=str))
    except OSError as exc:
        raise SweepError(f"{out}: cannot write there ({exc.strerror or exc}); choose "
                         "another folder") from None
    for stale in (out / RUNS).glob(".tmp-*"):
        shutil.rmtree(stale, ignore_errors=True)
    for stale in (out / RUNS).glob(".old-*"):
        shutil.rmtree(stale, ignore_errors=True)
    return out


def finished_records(out: Path, runs: list[Run], outputs_key: str) -> dict[str, dict]:
    """``{id: record}`` of the runs whose folders are complete with these outputs (their
    ``run.json`` exists: it is written last, and the folder renamed into place after it).
    """
    done = {}
    for r in runs:
        path = run_dir(out, r.id) / "run.json"
        try:
            record = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if record.get("status") == "done" and record.get("outputs_key") == outputs_key:
            done[r.id] = record
    return done


def _client(client, scheduler, workers, timeout: float):
    """``(client, close)``: the client to use and what to call when done."""
    try:
        from distributed import Client
    except ImportError:
        raise SweepError("sweeps need Dask: pip install 'wrinkle-vis[sweep]'") from None
    if client is not None:
        return client, lambda: None
    if scheduler is not None:
        try:
            c = Client(scheduler, timeout=f"{timeout}s")
        except (OSError, TimeoutError, ValueError) as exc:
            why = " ".join(str(exc).split())
            raise SweepError(f"cannot reach the Dask scheduler at {scheduler} ({why}); "
                             "check the address, or start one with 'dask scheduler'"
                             ) from None
        return c, c.close
    cluster = local_cluster(workers or _cpus())
    c = Client(cluster)

    def close():
        c.close()
        cluster.close()

    return c, close


#: Dask settings of the local cluster's workers: spawned (never forked from a process that
#: may hold an OpenGL context); without the statistical profiler, which samples a task's
#: stack every 10 ms while holding the GIL and keeps every stack it saw (on a sweep's deep
#: VTK and numpy stacks: about 45 KiB of worker memory per run); and without the
#: ``MALLOC_TRIM_THRESHOLD_=65536`` Dask's nanny sets by default, which made a run of the
#: example's kind take 0.44 s instead of 0.31 s (glibc then returns and maps memory again
#: for every large numpy temporary; None unsets it).
LOCAL_WORKER_CONFIG = {"distributed.worker.multiprocessing-method": "spawn",
                       "distributed.worker.daemon": True,
                       "distributed.worker.profile.enabled": False,
                       "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}


def local_cluster(workers: int):
    """A ``distributed.LocalCluster`` of ``workers`` spawned worker processes, one thread
    each, with :data:`LOCAL_WORKER_CONFIG`. The scheduler's HTTP server (its health and
    metrics routes; no dashboard without bokeh) takes any free port: with
    ``dashboard_address=None`` it still asked for 8787 and, where a dashboard or another
    cluster holds that port, warned and moved (an error where warnings are errors).
    """
    import dask
    from distributed import LocalCluster

    with dask.config.set(LOCAL_WORKER_CONFIG):
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                            dashboard_address=":0", silence_logs=logging.ERROR)


def _cpus() -> int:
    """The CPUs this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _task(spec: SweepSpec, out: Path, run: Run) -> dict:
    return {**_shared(spec, out), **_item(run)}


def _shared(spec: SweepSpec, out: Path) -> dict:
    """What every run of a sweep's tasks shares (sent once per batch)."""
    return {"outputs": spec.outputs, "outputs_key": spec.outputs_key(),
            "out": str(out.resolve())}


def _item(run: Run) -> dict:
    return {"id": run.id, "seed": run.seed, "params": run.params, "columns": run.columns,
            "layout_path": run.layout_path, "track_path": run.track_path}


def batch_sizes(n: int, threads: int, max_batch: int = MAX_BATCH) -> list[int]:
    r"""How many runs each Dask task of a sweep of ``n`` runs does, in the order submitted.

    Guided self-scheduling: each batch takes :math:`\max(1, \min(B, \lfloor r / (4 T)
    \rfloor))` of the :math:`r` runs left (``B`` = ``max_batch``, ``T`` = ``threads``), so
    a long sweep pays the scheduler's cost per task (about 25 ms of the client's process a
    task, a sixth of a paper-size run) on a few runs at a time, and the last batches are
    single runs that even out the workers' finishing times. Dask starts tasks in the order
    submitted.
    """
    sizes, left = [], n
    while left > 0:
        size = max(1, min(max_batch, left // (BATCH_SPREAD * max(threads, 1))))
        sizes.append(size)
        left -= size
    return sizes


def _threads(client) -> int:
    """The worker threads of ``client``'s cluster (1 when it tells none)."""
    try:
        workers = client.scheduler_info()["workers"].values()
        return max(sum(int(w.get("nthreads", 1)) for w in workers), 1)
    except (KeyError, TypeError, AttributeError, OSError):
        return 1


def _run_all(spec, out, pending, client, scheduler, workers, progress, timeout) -> dict:
    from distributed import as_completed
    from tqdm import tqdm

    client, close = _client(client, scheduler, workers, timeout)
    records: dict[str, dict] = {}
    futures = []
    bar = tqdm(total=len(pending), desc=spec.name, unit="run", disable=not progress,
               file=sys.stderr)
    try:
        shared, ids, start = _shared(spec, out), {}, 0
        for size in batch_sizes(len(pending), _threads(client)):
            batch = pending[start:start + size]
            start += size
            futures.append(client.submit(execute_batch, shared, [_item(r) for r in batch],
                                         pure=False))
            ids[futures[-1].key] = [r.id for r in batch]
        failed = 0
        for future, result in as_completed(futures, with_results=True, raise_errors=False):
            if future.status != "finished":  # the worker died, or the task could not run
                result = _lost_batch(out, ids[future.key], spec.outputs_key(), result)
            for record in result:
                records[record["id"]] = record
                failed += record["status"] != "done"
            bar.update(len(result))
            if failed:
                bar.set_postfix(failed=failed)
            future.release()
    except KeyboardInterrupt:
        bar.close()
        client.cancel(futures)
        close()
        raise
    bar.close()
    close()
    return records


def _lost_batch(out: Path, ids: list[str], outputs_key: str, error) -> list[dict]:
    """The records of a batch whose task failed as a whole: a run that finished before
    (its folder complete) is kept, the others are recorded as failed with the error.
    """
    exc = error[1] if isinstance(error, tuple) and len(error) == 3 else error
    if not isinstance(exc, BaseException):
        exc = RuntimeError(str(exc))
    out_records = []
    for rid in ids:
        path = run_dir(out, rid) / "run.json"
        try:
            record = json.loads(path.read_text())
        except (OSError, ValueError):
            record = None
        if (record is None or record.get("status") != "done"
                or record.get("outputs_key") != outputs_key):
            record = _lost(out, rid, exc)
        out_records.append(record)
    return out_records


def _lost(out: Path, rid: str, exc: BaseException) -> dict:
    message = " ".join(f"{type(exc).__name__}: {exc}".split())
    record = {"id": rid, "status": "failed", "error": message, "metrics": {}, "files": []}
    atomic_write_text(out / FAILED / f"{rid}.json", json.dumps(record, indent=1))
    return record


# ---------------------------------------------------------------------- the table
def table_frame(runs: list[Run], records: Mapping[str, dict]):
    """The sweep's table as a ``pandas.DataFrame``, one row per run, sorted by run id.

    Columns: ``run_id``, ``seed``, ``status`` (``done``, ``failed`` or ``missing``),
    ``error`` (one line, for a failed run), the run's parameters (``face``, ``n_triangles``,
    ``expression``, ``intensity``, ``time_s``, ``refine``, ``skin_model``, then one column
    per varied parameter, named by its label, e.g. ``type:sheet.n_wrinkles``), every metric of
    :data:`~wrinkle_vis.core.metrics.METRICS` in its order, then ``crests:<muscle>`` per
    muscle, sorted. Counts are nullable integers, ``folds_intersect`` a nullable boolean.
    """
    import pandas as pd

    rows, extra = [], set()
    for r in sorted(runs, key=lambda r: r.id):
        rec = records.get(r.id, {})
        row = {"run_id": r.id, "seed": r.seed, "status": rec.get("status", "missing"),
               "error": rec.get("error")}
        row.update(r.columns)
        metrics = rec.get("metrics") or {}
        row.update({k: metrics.get(k) for k in METRICS if k != "time_s"})
        for k, v in metrics.items():
            if k not in METRICS:
                row[k] = v
                extra.add(k)
        rows.append(row)
    head = list(rows[0]) if rows else ["run_id"]
    columns = [c for c in head if c not in extra] + sorted(extra)
    frame = pd.DataFrame(rows, columns=columns)
    counts = [k for k, (unit, _) in METRICS.items() if unit == "count"] + sorted(extra)
    for c in [*counts, "n_triangles", "seed"]:
        if c in frame:
            frame[c] = frame[c].astype("Int64")
    if "time_s" in frame:
        frame["time_s"] = frame["time_s"].astype(float)
    for c in ("folds_intersect", "refine"):
        if c in frame:
            frame[c] = frame[c].astype("boolean")
    for c in ("error",):
        frame[c] = frame[c].astype("string")
    return frame.reset_index(drop=True)


def write_table(frame, path: str | os.PathLike) -> Path:
    """Write the table as Parquet (pyarrow), atomically; returns the file."""
    buffer = io.BytesIO()
    frame.to_parquet(buffer, index=False, engine="pyarrow")
    return atomic_write_bytes(path, buffer.getvalue())

