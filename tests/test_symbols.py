"""Fields and parameters read with the paper's symbols (issue 32): one description in the
core (FieldSpec, Parameter) gives the labels of the app, the scalar bars and the probe; the
API names stay ASCII.
"""

from __future__ import annotations

import pytest

import wrinkle_vis as wv
from wrinkle_vis.core.fields import FIELDS, field_spec
from wrinkle_vis.core.muscles import LinearMuscle, SheetMuscle
from wrinkle_vis.core.skin import SkinMaterial
from wrinkle_vis.core.symbols import display_label, pretty_symbol


@pytest.mark.parametrize(("symbol", "shown"), [
    ("k_0", "k₀"), ("h^c", "hᶜ"), ("R_s", "Rₛ"), ("τ_a", "τₐ"), ("φ_c", "φ_c"), ("Φ", "Φ"),
    ("m_A", "m_A")])
def test_pretty_symbols_use_the_scripts_unicode_has(symbol, shown):
    assert pretty_symbol(symbol) == shown


def test_parameters_are_labelled_with_their_symbols_and_keep_their_names():
    linear = {p.name: p for p in LinearMuscle.parameters()}
    sheet = {p.name: p for p in SheetMuscle.parameters()}
    assert linear["max_angle_deg"].display == "Φ (deg)"
    assert linear["attenuation_start_deg"].display == "φ_c (deg)"
    assert linear["k0"].display == "k₀" and linear["alpha"].display == "α"
    assert linear["lambda_w"].display == "λ_w"
    assert sheet["attenuation_start"].display == "hᶜ"
    assert sheet["depth"].display == "depth"  # a label in words stays
    skin = {p.name: p for p in SkinMaterial.parameters()}
    assert skin["attachment_stiffness"].display == "κ (N/m³)"
    assert linear["k0"].label == "k0" and linear["k0"].name == "k0"  # the API is ASCII
    assert display_label("taper H at the ends", "T") == "taper H at the ends"


def test_every_field_shows_its_symbol_and_name_and_no_two_differ_only_by_case():
    shown = [spec.display for spec in FIELDS.values()]
    assert len({s.casefold() for s in shown}) == len(shown), shown
    assert field_spec("lambda").display == "λ (length factor)"
    assert field_spec("W").display == "W (wrinkle amplitude)"
    assert field_spec("w").display == "w (periodic coordinate)"
    assert field_spec("eps").display_label() == "ε"
    assert field_spec("W").display_label("cm") == "W (cm)"
    assert field_spec("gamma").display_title("corrugator_L") == "γ, corrugator_L"
    assert field_spec("lambda").title("m").isascii()  # the bar's name stays ASCII


def test_a_scalar_bar_shows_the_symbol_in_a_font_that_has_it(wv_face, wv_plotter):
    """VTK's own font draws nothing for Greek letters: the title is drawn in a font that
    has them, so it is wider than the title without its symbol.
    """
    import vtkmodules.vtkRenderingFreeType  # noqa: F401
    from vtkmodules.vtkRenderingCore import vtkTextRenderer

    from wrinkle_vis.plotting import add_skin

    state = wv_face.evaluate("surprise")
    add_skin(wv_plotter, state, "lambda", "frontalis_major_L")
    bar = wv_plotter.scalar_bars["lambda, frontalis_major_L"]  # known by its ASCII name
    assert bar.GetTitle().rstrip() == "λ, frontalis_major_L"
    renderer, prop = vtkTextRenderer(), bar.GetTitleTextProperty()
    widths = []
    for text in ("λ, frontalis_major_L", ", frontalis_major_L"):
        box = [0, 0, 0, 0]
        renderer.GetBoundingBox(prop, text, box, 72)
        widths.append(box[1] - box[0])
    assert widths[0] >= widths[1] + 4, widths
    add_skin(wv_plotter, state, "W")
    assert wv_plotter.scalar_bars["W (mm), total"].GetTitle().rstrip() == "W (mm), total"
    assert wv.FIELD_NAMES[0] == "lambda"
