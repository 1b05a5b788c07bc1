"""Issue 27: the default skin model is declared once in core (``DEFAULT_SKIN_MODEL``, with its
size policy ``default_skin_model``) and every layer that has a default reads it: the face,
layout files, the command line, the app's saved layouts and sweeps."""

import dataclasses

import pytest
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.core import skin as skin_module
from wrinkle_vis.core.skin import (
    DEFAULT_SKIN_MODEL,
    PHYSICAL_DEFAULT_MAX_POINTS,
    SKIN_MODELS,
    default_skin_model,
    default_skin_notice,
)


def test_the_default_is_one_of_the_skin_models_and_the_physical_one():
    assert DEFAULT_SKIN_MODEL in SKIN_MODELS
    assert DEFAULT_SKIN_MODEL == "physical"  # chosen by measurement (README, "Which skin")


def test_the_default_is_geometric_above_the_size_whose_first_physical_frame_fits_the_budget():
    """Issue 33's first frame (10 s, 1 GB) holds up to PHYSICAL_DEFAULT_MAX_POINTS vertices on
    the physical skin (docs/benchmarks.md, stop 37); above it the default is geometric, said
    in one line that names the way back."""
    assert 40_000 < PHYSICAL_DEFAULT_MAX_POINTS < 163_000  # 81.6k triangles fit, 326k do not
    assert default_skin_model(PHYSICAL_DEFAULT_MAX_POINTS) == "physical"
    assert default_skin_notice(PHYSICAL_DEFAULT_MAX_POINTS) is None
    assert default_skin_model(PHYSICAL_DEFAULT_MAX_POINTS + 1) == "geometric"
    notice = default_skin_notice(650_000)
    assert "\n" not in notice and "650,000 vertices" in notice
    assert "geometric skin" in notice and "--skin-model physical" in notice


def test_a_face_above_the_size_opens_on_the_geometric_skin_unless_it_names_one(monkeypatch):
    monkeypatch.setattr(skin_module, "PHYSICAL_DEFAULT_MAX_POINTS", 24)
    assert wv.FaceModel(grid(5, 5)).skin_model == "geometric"  # 25 vertices
    assert wv.FaceModel(grid(4, 6)).skin_model == "physical"  # 24
    assert wv.FaceModel(grid(5, 5), skin_model="physical").skin_model == "physical"


def test_the_command_line_says_when_a_big_face_takes_the_geometric_skin(monkeypatch, capsys):
    from wrinkle_vis.cli import main

    monkeypatch.setattr(skin_module, "PHYSICAL_DEFAULT_MAX_POINTS", 400)  # 1000 triangles: 5xx
    assert main(["summary", "-e", "frown", "--triangles", "1000"]) == 0
    out, err = capsys.readouterr()
    assert "== frown (intensity 1, geometric skin," in out
    (note,) = [line for line in err.splitlines() if "--skin-model physical" in line]
    assert note.startswith("wrinkle-vis summary: note: the skin has ")
    assert main(["summary", "-e", "frown", "--triangles", "1000", "--skin-model",
                 "physical"]) == 0
    out, err = capsys.readouterr()
    assert "physical skin," in out and "--skin-model physical" not in err


def test_the_app_records_no_skin_model_for_a_big_face_on_its_default(monkeypatch):
    from wrinkle_vis.app.session import Session

    monkeypatch.setattr(skin_module, "PHYSICAL_DEFAULT_MAX_POINTS", 400)
    s = Session(wv.datasets.load_face(1000))
    assert s.face.skin_model == "geometric" and s.layout().skin_model is None
    s.set_face(s.with_skin_model("physical"))
    assert s.layout().skin_model == "physical"


def test_a_face_built_without_a_skin_model_and_the_built_in_faces_use_the_default():
    assert wv.FaceModel(grid(5, 5)).skin_model == DEFAULT_SKIN_MODEL
    assert wv.datasets.load_face(1000).skin_model == DEFAULT_SKIN_MODEL


def test_a_layout_without_a_skin_model_opens_on_the_default_and_one_that_names_it_holds(
        tmp_path):
    from wrinkle_vis.core.layout import load_layout, save_layout
    from wrinkle_vis.datasets.face import BUILTIN_LAYOUT

    base = load_layout(BUILTIN_LAYOUT)
    assert base.skin_model is None
    assert wv.datasets.load_face(1000, layout=base).skin_model == DEFAULT_SKIN_MODEL
    path = tmp_path / "geometric.json"
    save_layout(dataclasses.replace(base, skin_model="geometric"), path)
    assert wv.datasets.load_face(1000, layout=path).skin_model == "geometric"


def test_the_command_line_says_its_default_and_summary_names_the_skin(capsys):
    from wrinkle_vis.cli import SKIN_MODEL_CHOICES, main

    assert SKIN_MODEL_CHOICES == SKIN_MODELS
    with pytest.raises(SystemExit):
        main(["summary", "--help"])
    assert f"else {DEFAULT_SKIN_MODEL}" in " ".join(capsys.readouterr().out.split())
    assert main(["summary", "-e", "frown", "--triangles", "1000"]) == 0
    assert f"== frown (intensity 1, {DEFAULT_SKIN_MODEL} skin," in capsys.readouterr().out


def test_a_sweep_spec_without_a_skin_model_runs_the_default():
    from wrinkle_vis.sweep import load_spec
    from wrinkle_vis.sweep.spec import ID_SKIN_MODEL

    spec = load_spec({"name": "s", "faces": [{"name": "procedural", "n_triangles": 1000}],
                      "expressions": ["frown"]})
    assert spec.skin_models == (DEFAULT_SKIN_MODEL,)
    (run,) = spec.runs()
    assert run.columns["skin_model"] == DEFAULT_SKIN_MODEL
    # a run's id names its skin model unless it is the one every run had before skin models
    assert ("skin_model" in run.params) == (DEFAULT_SKIN_MODEL != ID_SKIN_MODEL)
