"""Sweeps (wrinkle_vis.sweep): specs checked before any run, runs named by their parameters,
one table; the same table from local workers, from a scheduler and workers started apart,
and from a sweep killed half way and resumed.

Every cluster here is started and stopped by the test itself, on 127.0.0.1.
"""

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import wrinkle_vis as wv
from wrinkle_vis.core.layout import save_layout
from wrinkle_vis.sweep import SweepError, SweepSpecError, load_spec, run_id
from wrinkle_vis.sweep.runner import table_frame, write_table

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "sweep.toml"
#: The one column that differs between two runs of the same parameters.
TIMING = ["frame_seconds"]

TINY = """
name = "tiny"
seed = 3
samples = 2
faces = [{ name = "procedural", n_triangles = 1000 }]
expressions = ["surprise", "frown"]
skin_model = ["geometric"]  # the sweep's machinery, on the quicker skin

[[vary]]
type = "sheet"
parameter = "n_wrinkles"
values = [2, 3]

[[vary]]
muscles = ["corrugator_L", "corrugator_R"]
parameter = "k0"
random = { low = 1.0, high = 3.0 }

[outputs]
arrays = ["W", "points", "eps"]
images = { fields = ["W", "none"], cameras = ["front"], size = [64, 64] }
"""


def write_spec(folder: Path, text: str = TINY, name: str = "spec.toml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def spec_with(tmp_path, **changes) -> Path:
    """TINY as JSON with top-level keys changed."""
    import tomllib

    data = tomllib.loads(TINY)
    data.update(changes)
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(data))
    return path


def comparable(table: pd.DataFrame) -> pd.DataFrame:
    return table.drop(columns=TIMING)


def arrays_of(out: Path) -> dict:
    found = {}
    for path in sorted((out / "runs").glob("*/arrays.npz")):
        with np.load(path) as data:
            found[path.parent.name] = {k: data[k] for k in data.files}
    return found


def assert_same_arrays(a: dict, b: dict) -> None:
    assert a.keys() == b.keys() and a
    for rid in a:
        assert a[rid].keys() == b[rid].keys()
        for key in a[rid]:
            assert a[rid][key].tobytes() == b[rid][key].tobytes(), (rid, key)


# ---------------------------------------------------------------------- specs
def test_the_spec_expands_to_named_seeded_runs(tmp_path):
    spec = load_spec(write_spec(tmp_path))
    runs = spec.runs()
    assert len(runs) == 2 * 2 * 2  # expressions x n_w values x samples
    assert len({r.id for r in runs}) == len(runs)
    again = load_spec(write_spec(tmp_path, name="again.toml")).runs()
    assert [r.id for r in runs] == [r.id for r in again]
    assert all(r.seed == int(r.id[:8], 16) for r in runs)
    assert runs[0].id == run_id(json.loads(json.dumps(runs[0].params)))
    sheets = [m.name for m in wv.datasets.builtin_muscles() if m.type_name == "sheet"]
    assert sorted(runs[0].params["set"]) == sorted([*sheets, "corrugator_L", "corrugator_R"])
    draws = {r.columns["corrugator_L+corrugator_R.k0"] for r in runs}
    assert len(draws) == 2 and all(1.0 <= k < 3.0 for k in draws)
    other = load_spec(spec_with(tmp_path, seed=4)).runs()
    assert {r.columns["corrugator_L+corrugator_R.k0"] for r in other} != draws


def test_a_layout_faces_run_id_does_not_depend_on_where_the_file_lies(tmp_path):
    ids = []
    for where in ("here", "there/deeper"):
        folder = tmp_path / where
        folder.mkdir(parents=True)
        save_layout(wv.datasets.builtin_layout(), folder / "face.json")
        spec = load_spec(write_spec(folder, TINY.replace(
            'faces = [{ name = "procedural", n_triangles = 1000 }]',
            'faces = [{ layout = "face.json", n_triangles = 1000 }]')))
        runs = spec.runs()
        assert runs[0].layout_path == str(folder / "face.json")
        ids.append([r.id for r in runs])
    assert ids[0] == ids[1]


def test_the_example_spec_is_valid():
    assert len(load_spec(EXAMPLE).runs()) == 18


BAD = [
    ({"vary": [{"muscle": "nose", "parameter": "k0", "values": [1.0]}]},
     "vary[0].muscle: face procedural@1000 has no muscle 'nose'; its muscles are"),
    ({"vary": [{"type": "sheet", "parameter": "depth_of_field", "values": [1.0]}]},
     "vary[0].parameter: sheet muscles have no parameter 'depth_of_field'; they have:"),
    ({"vary": [{"type": "ring", "parameter": "k0", "values": [1.0]}]},
     "vary[0].type: face procedural@1000 has no 'ring' muscles"),
    ({"vary": [{"type": "sheet", "parameter": "k0", "values": [0.5, -1.0]}]},
     "vary[0].values[1]: k0 = -1 is outside its range [0, inf)"),
    ({"vary": [{"type": "sheet", "parameter": "lambda_w", "values": [1.0]}]},
     "vary[0].values[0]: lambda_w = 1 is outside its range [0, 1)"),
    ({"vary": [{"type": "sheet", "parameter": "n_wrinkles", "values": [2.5]}]},
     "vary[0].values[0]: n_wrinkles = 2.5 is not an integer"),
    ({"vary": [{"type": "sheet", "parameter": "alpha", "random": {"low": 0, "high": 12}}]},
     "vary[0].random.high: alpha = 12 is outside its range [-1, 10] (alpha < -1"),
    ({"vary": [{"type": "sheet", "parameter": "k0", "values": []}]},
     "vary[0].values: is empty; give at least one value"),
    ({"vary": [{"type": "sheet", "parameter": "k0",
                "grid": {"start": 0, "stop": 1, "num": 0}}]},
     "vary[0].grid.num: the grid is empty: num = 0; give num >= 1"),
    ({"vary": [{"type": "sheet", "parameter": "k0",
                "grid": {"start": 1, "stop": 0, "step": 0.5}}]},
     "vary[0].grid: the grid is empty: no step of 0.5 leads from 1 to 0"),
    ({"expressions": []}, "expressions: is empty; list at least one value"),
    ({"expressions": ["yawn"]}, "expressions[0]: face procedural@1000 has no expression 'yawn'"),
    ({"faces": [{"name": "procedural", "n_triangles": 100}]},
     "faces[0].n_triangles: 100 is outside the supported 500..250000"),
    ({"faces": ["marble_bust"]}, "faces[0].name: no built-in face 'marble_bust'"),
    ({"intensity": [1.5]}, "intensity[0]: 1.5 is outside [0, 1]"),
    ({"colour": "red"}, "colour: unknown key; the keys are:"),
    ({"vary": [{"muscle": "corrugator_L", "parameter": "strength", "values": [40.0]}]},
     "vary: face procedural@1000: linear muscle 'corrugator_L': parameter strength = 40"),
    ({"vary": [{"type": "sheet", "parameter": "attachment_line", "values": [1]}]},
     "vary[0].parameter: 'attachment_line' is a point parameter"),
    ({"outputs": {"images": {"size": [4, 4]}}},
     "outputs.images.size: expected [width, height], 16 to 8192 pixels each"),
    ({"outputs": {"meshes": ["stl"]}}, "outputs.meshes: expected a list of vtp, ply, glb"),
]


@pytest.mark.parametrize(("change", "message"), BAD, ids=[m.split(":")[0] for _, m in BAD])
def test_a_bad_spec_is_one_line_before_anything_runs(tmp_path, change, message):
    spec = spec_with(tmp_path, **change)
    out = tmp_path / "out"
    with pytest.raises(SweepSpecError) as caught:
        wv.sweep(spec, out)
    text = str(caught.value)
    assert "\n" not in text and text.startswith(f"{spec}: ")
    assert message in text, text
    assert not out.exists()  # nothing ran, nothing was written


def test_a_random_parameter_needs_samples(tmp_path):
    import tomllib

    data = tomllib.loads(TINY)
    del data["samples"]
    with pytest.raises(SweepSpecError, match=r"samples: a random parameter needs"):
        load_spec(data)


def test_the_command_prints_a_bad_spec_in_one_line(tmp_path, capsys):
    from wrinkle_vis.cli import main

    spec = spec_with(tmp_path, intensity=[2.0])
    assert main(["sweep", str(spec), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("wrinkle-vis sweep: ")
    assert "intensity[0]: 2 is outside [0, 1]" in err


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_an_unreachable_scheduler_is_one_line(tmp_path):
    address = f"tcp://127.0.0.1:{_free_port()}"  # nothing listens there
    with pytest.raises(SweepError) as caught:
        wv.sweep(write_spec(tmp_path), tmp_path / "out", scheduler=address,
                 connect_timeout_s=1.0, progress=False)
    text = str(caught.value)
    assert "\n" not in text
    assert text.startswith(f"cannot reach the Dask scheduler at {address}")
    assert text.endswith("check the address, or start one with 'dask scheduler'")
    assert not list((tmp_path / "out" / "runs").iterdir())  # no run started


def test_wv_sweep_is_callable_after_importing_the_module():
    import wrinkle_vis.sweep as module

    assert wv.sweep is module and callable(wv.sweep)


def test_local_workers_are_spawned_without_the_profiler_and_malloc_trim():
    import dask
    from distributed.nanny import _get_env_variables

    from wrinkle_vis.sweep.runner import LOCAL_WORKER_CONFIG

    assert "MALLOC_TRIM_THRESHOLD_" in _get_env_variables("distributed.nanny.pre-spawn-environ")
    with dask.config.set(LOCAL_WORKER_CONFIG):
        env = _get_env_variables("distributed.nanny.pre-spawn-environ")
        assert "MALLOC_TRIM_THRESHOLD_" not in env and env["OMP_NUM_THREADS"] == "1"
        assert dask.config.get("distributed.worker.profile.enabled") is False
        assert dask.config.get("distributed.worker.multiprocessing-method") == "spawn"


def test_a_local_cluster_starts_beside_a_dashboard_on_8787():
    """Another Dask dashboard (or anything) on port 8787: the local cluster still starts,
    with no warning (warnings are errors in the suite), on a free port of its own."""
    from wrinkle_vis.sweep.runner import local_cluster

    held = socket.socket()
    try:
        held.bind(("", 8787))
        held.listen()
    except OSError:  # (already held by someone else: the same situation)
        pass
    try:
        with local_cluster(1) as cluster:
            assert cluster.scheduler_address.startswith("tcp://")
    finally:
        held.close()


def test_the_sweep_layer_imports_no_qt():
    code = ("import sys, wrinkle_vis.sweep, wrinkle_vis.sweep.worker; "
            "print([m for m in ('qtpy', 'PySide6', 'pyvistaqt') if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_the_table_of_8_runs_round_trips_with_its_types(tmp_path):
    spec = load_spec(write_spec(tmp_path))
    runs = spec.runs()
    records = {r.id: {"status": "done", "error": None,
                      "metrics": {"W_range": 1.0, "crests": 3, "folds_intersect": False,
                                  "crests:frontalis_major_L": 2}} for r in runs[1:]}
    records[runs[0].id] = {"status": "failed", "error": "ValueError: no", "metrics": {}}
    table = table_frame(runs, records)
    write_table(table, tmp_path / "t.parquet")
    back = pd.read_parquet(tmp_path / "t.parquet")
    pd.testing.assert_frame_equal(back, table)
    assert list(table["run_id"]) == sorted(r.id for r in runs)
    assert str(table["crests"].dtype) == "Int64" and str(table["folds_intersect"].dtype) == \
        "boolean"
    failed = table[table["status"] == "failed"]
    assert len(failed) == 1 and failed["error"].iloc[0] == "ValueError: no"
    assert failed["crests"].isna().all()


def test_a_worker_writes_a_run_with_its_one_plotter(tmp_path):
    """In process, as a worker does it: two runs share the worker's one plotter, each
    image is rendered afresh, the run folders are complete, a time on the ramp is used.
    """
    import pyvista as pv

    from wrinkle_vis.sweep import worker
    from wrinkle_vis.sweep.runner import _prepare, _task

    spec = load_spec(spec_with(tmp_path, expressions=["frown"], times_s=[0.5, 1.5],
                               vary=[], samples=1))
    out = _prepare(tmp_path / "out", spec)
    before = len(pv.plotting.plotter._ALL_PLOTTERS)
    try:
        records = [worker.execute(_task(spec, out, r)) for r in spec.runs()]
        made = len(pv.plotting.plotter._ALL_PLOTTERS) - before
        (plotter,) = worker._PLOTTER.values()
    finally:
        worker.close_worker_plotter()
    assert made == 1 and plotter._closed
    assert [r["status"] for r in records] == ["done", "done"]
    early, peak = (r["metrics"] for r in records)
    assert early["time_s"] == 0.5 and peak["time_s"] == 1.5
    assert 0 < early["W_range"] < peak["W_range"]  # half way up the onset, then held
    import imageio.v3 as iio

    a, b = (iio.imread(out / "runs" / r["id"] / "W_front.png") for r in records)
    assert not np.array_equal(a, b)
    for r in records:
        assert sorted(p.name for p in (out / "runs" / r["id"]).iterdir()) == [
            "W_front.png", "arrays.npz", "none_front.png", "run.json"]
        saved = json.loads((out / "runs" / r["id"] / "run.json").read_text())
        assert saved["metrics"] == r["metrics"] and saved["seed"] == int(r["id"][:8], 16)
    assert not list((out / "runs").glob(".tmp-*"))


# ---------------------------------------------------------------------- clusters
@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny sweep on a local cluster of two spawned worker processes."""
    folder = tmp_path_factory.mktemp("reference")
    spec = write_spec(folder)
    table = wv.sweep(spec, folder / "out", workers=2, progress=False)
    return spec, folder / "out", table


@pytest.mark.slow
def test_a_local_sweep_writes_every_run_and_its_table(reference):
    spec, out, table = reference
    runs = load_spec(spec).runs()
    assert list(table["run_id"]) == sorted(r.id for r in runs)
    assert (table["status"] == "done").all() and table["error"].isna().all()
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), table)
    surprise = table[table["expression"] == "surprise"]
    assert (surprise["n_w"] == 6 * surprise["type:sheet.n_wrinkles"]).all()
    assert (surprise["active_muscles"] == 6).all() and (table["W_range"] > 0).all()
    for rid in table["run_id"]:
        folder = out / "runs" / rid
        record = json.loads((folder / "run.json").read_text())
        assert record["id"] == rid and record["status"] == "done"
        assert sorted(p.name for p in folder.iterdir()) == [
            "W_front.png", "arrays.npz", "none_front.png", "run.json"]
    # the worker's one plotter renders each image afresh (not the first one again)
    import imageio.v3 as iio

    first = out / "runs" / table["run_id"].iloc[0]
    coloured, plain = iio.imread(first / "W_front.png"), iio.imread(first / "none_front.png")
    assert coloured.shape == (64, 64, 3) and not np.array_equal(coloured, plain)
    with np.load(first / "arrays.npz") as data:
        assert data["W"].shape == (data["points"].shape[0],)
    assert not list((out / "runs").glob(".tmp-*"))


@pytest.mark.slow
def test_a_restarted_sweep_redoes_only_what_is_missing(reference, tmp_path):
    spec, out, table = reference
    import shutil

    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    gone = table["run_id"].iloc[2]
    shutil.rmtree(copy / "runs" / gone)
    (copy / "runs" / f".tmp-{gone}-leftover").mkdir()  # what a killed run leaves
    stamps = {p.parent.name: p.stat().st_mtime_ns for p in copy.glob("runs/*/run.json")}
    again = wv.sweep(spec, copy, workers=1, progress=False)
    pd.testing.assert_frame_equal(comparable(again), comparable(table))
    after = {p.parent.name: p.stat().st_mtime_ns for p in copy.glob("runs/*/run.json")}
    assert {k for k in after if after[k] != stamps.get(k)} == {gone}
    assert not list((copy / "runs").glob(".tmp-*"))
    assert_same_arrays(arrays_of(copy), arrays_of(out))


@pytest.mark.slow
def test_a_failing_run_is_recorded_and_the_sweep_goes_on(tmp_path):
    layout = wv.datasets.builtin_layout()
    from dataclasses import replace

    save_layout(replace(layout, skin="missing_head.obj"), tmp_path / "broken.json")
    spec = write_spec(tmp_path, TINY.replace(
        'faces = [{ name = "procedural", n_triangles = 1000 }]',
        'faces = [{ name = "procedural", n_triangles = 1000 }, { layout = "broken.json" }]'))
    table = wv.sweep(spec, tmp_path / "out", workers=2, progress=False)
    failed = table[table["face"] == "broken"]
    assert len(failed) == 8 and (failed["status"] == "failed").all()
    assert failed["error"].str.contains("missing_head.obj").all()
    assert (failed["error"].str.count("\n") == 0).all()
    done = table[table["face"] != "broken"]
    assert len(done) == 8 and (done["status"] == "done").all()
    assert len(list((tmp_path / "out" / "failed").glob("*.json"))) == 8


def _start(args: list[str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "dask", *args], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


@pytest.mark.slow
def test_a_scheduler_and_workers_started_apart_give_the_same_table(reference, tmp_path):
    spec, out, table = reference
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    processes = [_start(["scheduler", "--host", "127.0.0.1", "--port", str(port),
                         "--no-dashboard"])]
    try:
        for _ in range(2):
            processes.append(_start(["worker", address, "--nthreads", "1", "--nworkers", "1",
                                     "--no-dashboard", "--host", "127.0.0.1"]))
        from distributed import Client

        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
            apart = wv.sweep(spec, tmp_path / "out", client, progress=False)
    finally:
        for p in reversed(processes):
            _stop(p)
    pd.testing.assert_frame_equal(comparable(apart), comparable(table))
    assert_same_arrays(arrays_of(tmp_path / "out"), arrays_of(out))


@pytest.mark.slow
def test_ctrl_c_stops_the_command_cleanly(tmp_path):
    """SIGINT to the command's process group (what Ctrl+C in a terminal does): one line,
    exit status 130, no table, no worker process left; the finished runs stay.
    """
    import psutil

    target = tmp_path / "out"
    spec = write_spec(tmp_path)
    process = subprocess.Popen(
        [sys.executable, "-m", "wrinkle_vis.cli", "sweep", str(spec), "-o", str(target),
         "--workers", "2", "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, start_new_session=True)
    children = []
    try:
        deadline = time.monotonic() + 240
        while not list(target.glob("runs/*/run.json")):
            assert process.poll() is None and time.monotonic() < deadline
            time.sleep(0.02)
        children = psutil.Process(process.pid).children(recursive=True)
        os.killpg(process.pid, signal.SIGINT)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 130, err
    assert err.strip().splitlines()[-1] == (
        "wrinkle-vis sweep: interrupted; the finished runs are kept, run the same command "
        "again to resume")
    assert children
    _, alive = psutil.wait_procs(children, timeout=20)  # workers wind down after the parent
    assert not [c for c in alive if c.is_running() and c.status() != psutil.STATUS_ZOMBIE]
    assert not (target / "results.parquet").exists()
    assert list(target.glob("runs/*/run.json"))


@pytest.mark.slow
def test_a_sweep_killed_half_way_and_resumed_gives_the_same_table(reference, tmp_path):
    spec, out, table = reference
    target = tmp_path / "out"
    command = [sys.executable, "-m", "wrinkle_vis.cli", "sweep", str(spec), "-o", str(target),
               "--workers", "2", "--quiet"]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    try:
        deadline = time.monotonic() + 240
        while len(list(target.glob("runs/*/run.json"))) < len(table) // 2:
            assert process.poll() is None, "the sweep ended before it was killed"
            assert time.monotonic() < deadline
            time.sleep(0.02)
    finally:
        os.killpg(process.pid, signal.SIGKILL)  # the command and its worker processes
        process.wait()
    done = len(list(target.glob("runs/*/run.json")))
    assert len(table) // 2 <= done < len(table)
    assert not (target / "results.parquet").exists()
    resumed = wv.sweep(spec, target, workers=2, progress=False)
    pd.testing.assert_frame_equal(comparable(resumed), comparable(table))
    assert_same_arrays(arrays_of(target), arrays_of(out))
    pd.testing.assert_frame_equal(pd.read_parquet(target / "results.parquet"), resumed)


# ---------------------------------------------------------------------- batches
@pytest.mark.parametrize(("n", "threads"), [(0, 2), (1, 2), (7, 2), (50, 2), (200, 2),
                                            (1000, 16), (5, 0)])
def test_batches_cover_every_run_once_and_end_in_single_runs(n, threads):
    from wrinkle_vis.sweep.runner import MAX_BATCH, batch_sizes

    sizes = batch_sizes(n, threads)
    assert sum(sizes) == n and all(1 <= s <= MAX_BATCH for s in sizes)
    assert sizes == sorted(sizes, reverse=True)  # the big ones first, the single runs last
    tail = min(n, 4 * max(threads, 1))
    assert sizes[len(sizes) - tail:] == [1] * tail
    if n >= 200 and threads <= 2:
        assert len(sizes) <= n / 3  # a long sweep pays the scheduler on few tasks


def test_a_batch_lost_as_a_whole_keeps_its_finished_runs(tmp_path):
    from wrinkle_vis.sweep.runner import _lost_batch

    out = tmp_path / "out"
    (out / "runs" / "aa").mkdir(parents=True)
    (out / "failed").mkdir()
    done = {"id": "aa", "status": "done", "outputs_key": "k", "metrics": {"W_range": 1.0}}
    (out / "runs" / "aa" / "run.json").write_text(json.dumps(done))
    (out / "runs" / "cc").mkdir()  # written with other outputs: redone
    (out / "runs" / "cc" / "run.json").write_text(json.dumps({**done, "id": "cc",
                                                              "outputs_key": "old"}))
    error = (RuntimeError, RuntimeError("worker\nkilled"), None)
    records = _lost_batch(out, ["aa", "bb", "cc"], "k", error)
    assert records[0] == done
    assert [r["status"] for r in records] == ["done", "failed", "failed"]
    assert records[1]["error"] == "RuntimeError: worker killed"
    assert sorted(p.name for p in (out / "failed").iterdir()) == ["bb.json", "cc.json"]


@pytest.mark.slow
def test_a_sweep_in_batches_of_several_runs_gives_the_same_table(reference, tmp_path,
                                                                  monkeypatch):
    from wrinkle_vis.sweep import runner

    spec, out, table = reference
    monkeypatch.setattr(runner, "BATCH_SPREAD", 1)  # 8 runs on 2 threads: 4, 2, 1, 1
    assert runner.batch_sizes(len(table), 2) == [4, 2, 1, 1]
    batched = wv.sweep(spec, tmp_path / "out", workers=2, progress=False)
    pd.testing.assert_frame_equal(comparable(batched), comparable(table))
    assert_same_arrays(arrays_of(tmp_path / "out"), arrays_of(out))


# ---------------------------------------------------------------------- tracks, skin models
OPENFACE = ROOT.parent / "shared" / "tracks" / "openface_test.csv"


def _brows_track(folder: Path) -> Path:
    from wrinkle_vis.core.tracks import Track, write_track

    t = np.linspace(0.0, 1.0, 5)
    return write_track(Track(t, ["AU01", "AU04"], np.column_stack([t, 1.0 - t])),
                       folder / "brows.csv", "openface")


def test_a_track_is_swept_frame_by_frame_and_a_run_plays_it(tmp_path):
    from wrinkle_vis.core.tracks import default_mapping, performance, read_track
    from wrinkle_vis.sweep import worker
    from wrinkle_vis.sweep.runner import _prepare, _task

    _brows_track(tmp_path)
    spec = load_spec(spec_with(tmp_path, expressions=[{"track": "brows.csv"}], vary=[],
                               samples=1, outputs={"arrays": ["W"]}))
    runs = spec.runs()
    assert [r.columns["time_s"] for r in runs] == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    assert {r.columns["expression"] for r in runs} == {"brows"}
    assert runs[0].params["expression"]["track"] == "brows.csv"  # the name, not the path
    assert runs[0].track_path == str(tmp_path / "brows.csv")
    again = load_spec(spec_with(tmp_path, expressions=[{"track": "brows.csv"}], vary=[],
                                samples=1, times_s=[0.25], outputs={"arrays": ["W"]})).runs()
    assert [r.id for r in again] == [runs[1].id]  # a time asked for: the same run
    out = _prepare(tmp_path / "out", spec)
    record = worker.execute(_task(spec, out, runs[1]))
    assert record["status"] == "done", record.get("error")
    face = wv.datasets.load_face(1000)
    perf = performance(read_track(tmp_path / "brows.csv"), default_mapping(),
                       face.muscle_names)
    expected = face.evaluate(perf.at(0.25), skin="geometric")
    with np.load(out / "runs" / runs[1].id / "arrays.npz") as data:
        np.testing.assert_array_equal(data["W"], expected.W)  # AU01 0.25, AU04 0.75
    assert record["metrics"]["time_s"] == 0.25 and record["metrics"]["W_range"] > 0


def test_the_real_openface_track_expands_to_its_frames(tmp_path):
    spec = load_spec(spec_with(tmp_path, expressions=[
        {"track": str(OPENFACE), "resample_fps": 50}], vary=[], samples=1))
    assert [r.columns["time_s"] for r in spec.runs()] == pytest.approx(
        [0.0, 0.02, 0.04, 0.06, 0.08])
    assert load_spec(spec_with(tmp_path, expressions=[{"track": str(OPENFACE)}], vary=[],
                               samples=1)).runs()[-1].columns["time_s"] == pytest.approx(0.099)


@pytest.mark.parametrize(("expression", "times", "message"), [
    ({"track": "missing.csv"}, None, r"expressions\[0\]\.track: .*missing\.csv"),
    ({"track": "spec.toml"}, None, r"expressions\[0\]\.track: "),
    ({"track": "brows.csv", "speed": 2}, None, r"expressions\[0\]\.speed: unknown key"),
    ({"track": "brows.csv"}, [2.0], r"times_s\[0\]: 2 s is past the end of track brows\.csv"),
    ({"track": "brows.csv"}, [None], r"times_s\[0\]: a track \(brows\.csv\) has no peak"),
    ({"track": "blink.csv"}, None, r"blink\.csv drives none of face procedural@1000's"),
    ({"track": "brows.csv", "resample_fps": 0}, None, r"resample_fps: 0 is outside"),
])
def test_a_bad_track_is_one_line_before_anything_runs(tmp_path, expression, times, message):
    from wrinkle_vis.core.tracks import Track, write_track

    _brows_track(tmp_path)
    write_spec(tmp_path)  # spec.toml: a file that is not a track
    write_track(Track(np.linspace(0, 1, 3), ["AU45"], np.ones((3, 1))), tmp_path / "blink.csv",
                "openface")
    changes = {"expressions": [expression], "vary": [], "samples": 1}
    if times is not None:
        changes["times_s"] = times
    with pytest.raises(SweepSpecError, match=message) as info:
        wv.sweep(spec_with(tmp_path, **changes), tmp_path / "out", progress=False)
    assert "\n" not in str(info.value)
    assert not (tmp_path / "out").exists()


def test_the_physical_skin_is_swept_beside_the_geometric(tmp_path):
    from wrinkle_vis.sweep import worker
    from wrinkle_vis.sweep.runner import _prepare, _task

    plain = load_spec(spec_with(tmp_path, expressions=["frown"], vary=[], samples=1,
                                skin_model=["geometric"], outputs={"arrays": ["W"]}))
    both = load_spec(spec_with(tmp_path, expressions=["frown"], vary=[], samples=1,
                               skin_model=["geometric", "physical"],
                               outputs={"arrays": ["W"]}))
    geometric, physical = both.runs()
    assert geometric.id == plain.runs()[0].id  # ids from before skin models are kept
    assert (geometric.columns["skin_model"], physical.columns["skin_model"]) == (
        "geometric", "physical")
    assert physical.params["skin_model"] == "physical" and physical.id != geometric.id
    out = _prepare(tmp_path / "out", both)
    record = worker.execute(_task(both, out, physical))
    assert record["status"] == "done", record.get("error")
    face = wv.datasets.load_face(1000)
    expected = face.with_skin_model("physical").evaluate("frown")
    with np.load(out / "runs" / physical.id / "arrays.npz") as data:
        np.testing.assert_array_equal(data["W"], expected.W)
        assert not np.array_equal(data["W"], face.evaluate("frown", skin="geometric").W)


@pytest.mark.parametrize(("skin", "message"), [
    ("elastic", r"skin_model\[0\]: unknown skin model 'elastic'; choose one of geometric, "
                r"physical$"),
    (["physical", "physical"], r"skin_model: a skin model is listed twice"),
])
def test_a_bad_skin_model_is_one_line_before_anything_runs(tmp_path, skin, message):
    with pytest.raises(SweepSpecError, match=message):
        wv.sweep(spec_with(tmp_path, skin_model=skin), tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()
