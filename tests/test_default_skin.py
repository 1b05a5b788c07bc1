"""Issue 27: the default skin model is declared once in core (``DEFAULT_SKIN_MODEL``) and
every layer that has a default reads it: the face, layout files, the command line, the app's
saved layouts and sweeps."""

import dataclasses

import pytest
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.core.skin import DEFAULT_SKIN_MODEL, SKIN_MODELS


def test_the_default_is_one_of_the_skin_models_and_the_geometric_one():
    assert DEFAULT_SKIN_MODEL in SKIN_MODELS
    assert DEFAULT_SKIN_MODEL == "geometric"  # chosen by measurement (README, "Which skin")


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
