"""Sweeps: throughput on local workers against a plain serial loop, worker memory over many
runs, and the table of 10,000 runs.

Run:  .venv/bin/python benchmarks/bench_sweep.py [--runs 200] [--rounds 4] [--workers 2]
      [--memory-runs 1000] [--table-runs 10000] [--json out.json] [--old-runner REV]

1. ``--runs`` runs of surprise on the paper-size face (4,500 triangles), each with its own
   k0 of the sheet muscles (a seeded random draw), every metric and one 400 by 400 image
   (W, front camera, raking light), in ``--rounds`` rounds: in each, a plain loop in this
   process (the worker's own function, one plotter, the same files written), then a sweep
   on ``--workers`` warm local worker processes; the median of the rounds' ratios. With
   ``--old-runner REV`` (a git revision of this repository, e.g. ``57d9c56``: one run a Dask
   task), each round also runs a sweep of as many runs with that revision's
   ``wrinkle_vis/sweep/runner.py`` (on the same workers, with today's worker code), between
   the two. Besides wall seconds, each sweep's CPU seconds: this process's (the client and
   the local scheduler) and the workers' (their processes, asked over Dask), per run; under
   load they say more than the wall clock. Then one round's sweep with its own cluster
   started, to show what starting costs.
2. One worker process runs ``--memory-runs`` runs of the same kind (a 1,000-triangle face,
   100 runs a batch); its resident memory after each batch.
3. The table of ``--table-runs`` runs built and written (pandas, pyarrow, atomically) from
   records like a real run's, and the same number of ``run.json`` files read back as a
   restarted sweep reads them.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import wrinkle_vis as wv
from wrinkle_vis.sweep import load_spec
from wrinkle_vis.sweep.runner import (
    _task,
    finished_records,
    local_cluster,
    table_frame,
    write_table,
)
from wrinkle_vis.sweep.worker import close_worker_plotter, execute


def spec(runs: int, triangles: int, seed: int = 0, image: bool = True) -> dict:
    out = {"name": "bench", "seed": seed, "samples": runs,
           "faces": [{"name": "procedural", "n_triangles": triangles}],
           "expressions": ["surprise"],
           "vary": [{"type": "sheet", "parameter": "k0", "random": {"low": 0.5, "high": 6.0}}],
           "outputs": {}}
    if image:
        out["outputs"]["images"] = {"fields": ["W"], "cameras": ["front"], "size": [400, 400],
                                    "raking_light": True}
    return out


def serial(runs: int, triangles: int, folder: Path, seed: int = 0) -> float:
    """Seconds of a plain loop over the runs in this process (the worker's own function;
    the face loaded and the plotter made by one run first, not timed).
    """
    s = load_spec(spec(runs, triangles, seed=seed))
    (folder / "runs").mkdir(parents=True)
    (folder / "failed").mkdir()
    tasks = [_task(s, folder, r) for r in s.runs()]
    execute(tasks[0])
    shutil.rmtree(folder / "runs" / tasks[0]["id"])
    start = time.perf_counter()
    for task in tasks:
        assert execute(task)["status"] == "done"
    return time.perf_counter() - start


def parallel(runs: int, triangles: int, workers: int, folder: Path) -> float:
    """Seconds of ``wv.sweep`` starting its own local cluster (all included)."""
    start = time.perf_counter()
    table = wv.sweep(spec(runs, triangles), folder, workers=workers, progress=False)
    seconds = time.perf_counter() - start
    assert (table["status"] == "done").all() and len(table) == runs
    return seconds


def old_runner(rev: str):
    """``wrinkle_vis/sweep/runner.py`` at git revision ``rev``, as a module of the package
    (its relative imports get today's spec and worker).
    """
    import importlib.util
    import subprocess

    root = Path(__file__).resolve().parents[1]
    source = subprocess.run(["git", "-C", str(root), "show", f"{rev}:wrinkle_vis/sweep/runner.py"],
                            check=True, capture_output=True, text=True).stdout
    loaded = importlib.util.spec_from_loader("wrinkle_vis.sweep._old_runner", loader=None)
    module = importlib.util.module_from_spec(loaded)
    module.__package__ = "wrinkle_vis.sweep"
    sys.modules[loaded.name] = module
    exec(compile(source, f"{rev}:runner.py", "exec"), module.__dict__)
    return module


def _cpu() -> float:
    return time.process_time()


def _plotters() -> int:
    """The off-screen plotters this process has open (a worker keeps one for its life)."""
    import pyvista as pv

    return len(pv.plotting.plotter._ALL_PLOTTERS)


def timed_sweep(run, n: int, triangles: int, seed: int, folder: Path, client) -> dict:
    """Wall and CPU seconds of one sweep with ``run`` (a runner's ``sweep``)."""
    workers0 = client.run(_cpu)
    cpu0, start = time.process_time(), time.perf_counter()
    table = run(spec(n, triangles, seed=seed), folder, client, progress=False)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu0
    workers1 = client.run(_cpu)
    assert (table["status"] == "done").all() and len(table) == n
    return {"wall": wall, "client_cpu": cpu,
            "worker_cpu": sum(workers1[w] - workers0[w] for w in workers0)}


def side_by_side(runs: int, triangles: int, workers: int, rounds: int,
                 folder: Path, old=None) -> list[dict]:
    """``rounds`` times, one after the other under the same load: a plain loop of
    ``runs // rounds`` runs here, then (with ``old``, a runner module) a sweep of as many
    with ``old.sweep``, then one with today's, on a running cluster whose workers have
    loaded the face and made their plotter (two runs each first, not timed). Returns per
    round ``serial`` (wall s), ``serial_cpu``, and per sweep :func:`timed_sweep`'s.
    """
    from distributed import Client

    n = runs // rounds
    out = []
    with local_cluster(workers) as cluster, Client(cluster) as client:
        wv.sweep(spec(2 * workers, triangles, seed=99), folder / "warm", client,
                 progress=False)
        for k in range(rounds):
            cpu0 = time.process_time()
            row = {"serial": serial(n, triangles, folder / f"serial{k}", seed=100 + k)}
            row["serial_cpu"] = time.process_time() - cpu0
            if old is not None:
                row["old"] = timed_sweep(old.sweep, n, triangles, 300 + k,
                                         folder / f"old{k}", client)
            row["new"] = timed_sweep(wv.sweep, n, triangles, 200 + k, folder / f"sweep{k}",
                                     client)
            out.append(row)
            print(f"  round {k}: {n} runs, load {os.getloadavg()[0]:.1f}; serial "
                  f"{row['serial']:6.1f} s ({1e3 * row['serial_cpu'] / n:.0f} ms CPU a run)"
                  + "".join(_column(name, row[name], row["serial"], n)
                            for name in ("old", "new") if name in row), flush=True)
        made = client.run(_plotters)
        print(f"  plotters open in each worker after the rounds: {sorted(made.values())}")
        assert all(n == 1 for n in made.values()), made
    close_worker_plotter()
    return out


def _column(name: str, t: dict, serial_s: float, n: int) -> str:
    label = {"old": "old runner", "new": "sweep"}[name]
    return (f"; {label} {t['wall']:6.1f} s: {serial_s / t['wall']:.2f}x (CPU a run: client "
            f"{1e3 * t['client_cpu'] / n:.0f} ms, workers {1e3 * t['worker_cpu'] / n:.0f} ms)")


def rss() -> int:
    import psutil

    return psutil.Process().memory_info().rss


def memory(runs: int, folder: Path) -> list[tuple[int, float]]:
    from distributed import Client

    out = []
    with local_cluster(1) as cluster, Client(cluster) as client:
        done = 0
        for batch in range(runs // 100):
            wv.sweep(spec(100, 1000, seed=batch), folder, client, progress=False)
            done += 100
            mib = next(iter(client.run(rss).values())) / 2**20
            out.append((done, mib))
            print(f"  after {done:5d} runs: worker {mib:7.1f} MiB", flush=True)
    return out


def table(runs: int, folder: Path) -> dict:
    s = load_spec(spec(runs, 1000, image=False))
    all_runs = s.runs()
    metrics = {k: 0.5 for k in ("W_min", "W_max", "W_range", "crests_match",
                                "furrow_depth_median", "furrow_side_slope_deg_median",
                                "eps_mean", "eps_p95", "eps_max", "compressed_fraction",
                                "frame_seconds")}
    metrics.update({k: 3 for k in ("active_muscles", "wrinkling_muscles", "crests", "n_w",
                                   "furrows", "crossings_rest", "crossings",
                                   "crossings_added", "turned_over")})
    metrics.update({f"crests:frontalis_{p}_{s}": 3 for p in ("major", "inner", "outer")
                    for s in "LR"}, folds_intersect=False, time_s=None)
    records = {r.id: {"id": r.id, "status": "done", "error": None, "seed": r.seed,
                      "params": r.params, "columns": r.columns, "outputs_key": s.outputs_key(),
                      "metrics": dict(metrics, W_range=i / runs)}
               for i, r in enumerate(all_runs)}
    folder.mkdir(parents=True)
    start = time.perf_counter()
    frame = table_frame(all_runs, records)
    write_table(frame, folder / "results.parquet")
    written = time.perf_counter() - start
    for r in all_runs:
        (folder / "runs" / r.id).mkdir(parents=True)
        (folder / "runs" / r.id / "run.json").write_text(json.dumps(records[r.id]))
    start = time.perf_counter()
    back = finished_records(folder, all_runs, s.outputs_key())
    read = time.perf_counter() - start
    assert len(back) == runs == len(frame)
    return {"runs": runs, "build_and_write_s": written, "read_run_json_s": read,
            "bytes": (folder / "results.parquet").stat().st_size}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=200)
    p.add_argument("--rounds", type=int, default=4)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--triangles", type=int, default=4500)
    p.add_argument("--memory-runs", type=int, default=1000)
    p.add_argument("--table-runs", type=int, default=10_000)
    p.add_argument("--json", type=Path)
    p.add_argument("--old-runner", default=None, metavar="REV",
                   help="also time the sweep runner of this git revision, each round")
    args = p.parse_args()
    print(f"CPUs this process may use: {len(os.sched_getaffinity(0))}; load average "
          f"{os.getloadavg()[0]:.1f}", flush=True)
    result = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.runs:
            print(f"{args.runs} runs in {args.rounds} rounds, metrics and a 400x400 image each "
                  f"({args.triangles} triangles), {args.workers} workers:", flush=True)
            old = old_runner(args.old_runner) if args.old_runner else None
            rows = side_by_side(args.runs, args.triangles, args.workers, args.rounds,
                                tmp / "side", old)
            serial_s = sum(r["serial"] for r in rows)
            sweep_s = sum(r["new"]["wall"] for r in rows)
            ratio = statistics.median(r["serial"] / r["new"]["wall"] for r in rows)
            cold = parallel(max(args.runs // args.rounds, 1), args.triangles, args.workers,
                            tmp / "cold")
            result["throughput"] = {"rounds": rows, "serial_s": serial_s, "sweep_s": sweep_s,
                                    "median_ratio": ratio, "cold_sweep_s": cold}
            if old is not None:
                old_ratio = statistics.median(r["serial"] / r["old"]["wall"] for r in rows)
                result["throughput"]["old_median_ratio"] = old_ratio
                print(f"  old runner ({args.old_runner}): median ratio {old_ratio:.2f}x")
            print(f"  in all: serial {args.runs / serial_s:.2f} runs/s, sweep "
                  f"{args.runs / sweep_s:.2f} runs/s; median ratio {ratio:.2f}x\n"
                  f"  a sweep of {args.runs // args.rounds} runs starting its own cluster: "
                  f"{cold:.1f} s", flush=True)
        if args.memory_runs:
            print(f"worker memory over {args.memory_runs} runs (1,000-triangle face, "
                  "metrics and a 400x400 image each):", flush=True)
            result["memory"] = memory(args.memory_runs, tmp / "memory")
        if args.table_runs:
            t = table(args.table_runs, tmp / "table")
            result["table"] = t
            print(f"table of {t['runs']} runs: built and written in "
                  f"{t['build_and_write_s']:.2f} s ({t['bytes'] / 2**20:.1f} MiB); "
                  f"{t['runs']} run.json read back in {t['read_run_json_s']:.2f} s",
                  flush=True)
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    sys.exit(main())
