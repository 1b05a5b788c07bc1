"""One core catalogue of fields (issue 16): a field added with one entry reaches every layer."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import skin_mesh

import wrinkle_vis as wv
from wrinkle_vis import cli
from wrinkle_vis.core.fields import (
    FIELD_NAMES,
    FIELDS,
    FieldSpec,
    check_field,
    register_field,
    total_fields,
)
from wrinkle_vis.plotting import field_info, to_polydata

#: A field the paper does not name: the wrinkle shape attenuated, before compression.
HAT = FieldSpec("HAt", "H At", "attenuated shape", "H times At: the wrinkle before compression",
                "Eq. 5, 12", unit="length", where="region", signed=True,
                compute=lambda f: f["H"] * f["At"])


@pytest.fixture
def hat_field():
    register_field(HAT)
    try:
        yield HAT
    finally:
        FIELDS.pop("HAt")


def test_the_catalogue_describes_every_field_once():
    assert tuple(FIELD_NAMES) == ("lambda", "gamma", "l", "w", "H", "At", "eps", "A", "W")
    assert wv.FIELD_NAMES == FIELD_NAMES and wv.FIELDS is FIELDS
    assert total_fields() == ("W",)  # only W has a total (Eq. 4)
    for key, spec in FIELDS.items():
        assert spec.key == key and spec.equation.startswith("Eq.") and spec.where in (
            "aoi", "region")
        assert field_info(key) is spec  # plotting reads the core's entry
    assert {k for k, f in FIELDS.items() if f.where == "region"} == {"w", "H", "W"}


def test_only_w_has_a_total_checked_in_one_place():
    assert check_field("W") is FIELDS["W"]
    assert check_field("eps", "corrugator_L") is FIELDS["eps"]
    with pytest.raises(ValueError, match="'eps' belongs to one muscle; name the muscle "
                                         r"\(only W has a total\)"):
        check_field("eps")
    with pytest.raises(KeyError, match="unknown field 'nope'; fields: lambda, gamma"):
        check_field("nope")
    with pytest.raises(ValueError, match="cannot have a total: only W"):
        register_field(FieldSpec("sum", "s", "s", "s", "Eq. 0", total=True,
                                 compute=lambda f: f["W"]))
    with pytest.raises(ValueError, match="already in the catalogue"):
        register_field(FIELDS["H"])
    with pytest.raises(ValueError, match="needs compute"):
        FieldSpec("x", "x", "x", "x", "Eq. 0")


def test_a_registered_field_is_computed_and_exported(hat_field, wv_face):
    state = wv_face.evaluate("surprise")
    f = state.fields["frontalis_major_L"]
    assert "HAt" in list(f) and len(f) == len(FIELD_NAMES) == 10
    want = np.asarray(f["H"]) * np.asarray(f["At"])
    np.testing.assert_array_equal(f["HAt"], want)
    assert np.isfinite(f["HAt"]).sum() == np.isfinite(f["H"]).sum() > 0  # on the region only
    assert not f["HAt"].flags.writeable
    np.testing.assert_array_equal(state.field_values("HAt", "frontalis_major_L"), want)
    with pytest.raises(ValueError, match="belongs to one muscle"):
        state.field_values("HAt")
    mesh = to_polydata(state)
    np.testing.assert_array_equal(mesh["frontalis_major_L__HAt"], want)


def test_a_registered_field_is_one_of_the_cli_choices(hat_field, tmp_path, capsys):
    assert "HAt" in cli.field_choices()
    out = tmp_path / "hat.png"
    assert cli.main(["render", "-e", "surprise", "-f", "HAt", "-m", "frontalis_major_L",
                     "--size", "64", "64", "-o", str(out)]) == 0
    assert out.stat().st_size > 0
    assert cli.main(["render", "-f", "HAt", "-o", str(out)]) == 2
    assert "--field HAt belongs to one muscle: add --muscle NAME" in capsys.readouterr().err


def test_without_it_the_cli_refuses_the_field(capsys, tmp_path):
    with pytest.raises(SystemExit):
        cli.main(["render", "-f", "HAt", "-m", "x", "-o", str(tmp_path / "x.png")])
    assert "invalid choice: 'HAt'" in capsys.readouterr().err


@pytest.mark.usefixtures("no_leaked_plotters")
def test_a_registered_field_is_in_the_app_field_menu_and_drawn(hat_field, make_window):
    window = make_window()
    items = [window.field_box.itemText(i) for i in range(window.field_box.count())]
    assert "HAt" in items
    assert window.probe_table.rowCount() == len(FIELD_NAMES)
    window.muscle_box.setCurrentText("frontalis_major_L")
    window.field_box.setCurrentText("HAt")
    assert window.active_array() == "frontalis_major_L__HAt"
    mesh = skin_mesh(window)
    assert mesh.active_scalars_name == "frontalis_major_L__HAt"
    state = window.session.state()
    f = state.fields["frontalis_major_L"]
    np.testing.assert_allclose(mesh["frontalis_major_L__HAt"], f["H"] * f["At"])
    assert "HAt (mm), frontalis_major_L" in window.skin_view.scalar_bars
    window.muscle_box.setCurrentText("total")  # HAt has no total: back to W
    assert window.field_box.currentText() == "W"


def test_a_registered_field_works_on_refined_frames_too(hat_field, wv_face):
    state = wv_face.evaluate("surprise", refine=True)
    assert state.n_points > wv_face.skin.n_points  # refined
    f = state.fields["frontalis_major_L"]
    np.testing.assert_array_equal(f["HAt"], np.asarray(f["H"]) * np.asarray(f["At"]))
    assert np.isfinite(f["HAt"][wv_face.skin.n_points:]).any()  # on new vertices as well
