"""The app's rough edges (issue 32, polish): the Face menu marks the face shown and the
title names it, Pick landmarks again only where there are scan landmarks, dialogs wide
enough for their titles.
"""

from __future__ import annotations

import pytest
from qtpy import QtGui, QtWidgets

from wrinkle_vis.app.session import Session
from wrinkle_vis.core.layout import Layout


def checked_faces(w) -> list[str]:
    return [name for name, action in w.face_actions.items() if action.isChecked()]


def test_the_face_menu_checks_the_face_shown_and_the_title_names_it(make_window, answer):
    w = make_window()
    assert all(a.isCheckable() for a in w.face_actions.values())
    assert checked_faces(w) == ["procedural"]
    assert w.windowTitle() == "wrinkle-vis - built-in face Procedural"
    w.face_actions["lee_perry_smith"].trigger()
    assert checked_faces(w) == ["lee_perry_smith"]  # exclusive: Procedural unchecked
    assert w.windowTitle() == "wrinkle-vis - built-in face Lee Perry-Smith"
    w.select_muscle(w.session.face.muscle_names[0])
    w.param_widgets["k0"].setValue(w.param_widgets["k0"].value() * 1.5)  # unsaved
    answer("Cancel")
    w.face_actions["procedural"].trigger()  # cancelled: the face shown stays checked
    assert "unsaved changes" in answer.asked[-1]
    assert checked_faces(w) == ["lee_perry_smith"]
    assert w.windowTitle() == "wrinkle-vis - built-in face Lee Perry-Smith *"


def test_pick_landmarks_again_is_enabled_only_on_a_face_from_a_scan(make_window, wv_face,
                                                                   tmp_path):
    w = make_window()
    again = w.newface.actions["again"]
    assert not again.isEnabled()  # the procedural face: no scan landmarks to pick
    w.face_actions["lee_perry_smith"].trigger()
    assert not again.isEnabled()
    scan = Session(wv_face, layout=Layout(skin="head.ply", face=None), folder=tmp_path)
    w._show_session(scan)
    assert again.isEnabled()
    assert checked_faces(w) == []  # a scan is none of the built-in faces
    assert w.windowTitle() == "wrinkle-vis - new face from head.ply"


def test_the_rename_dialog_is_wide_enough_for_its_title(window, answer):
    """A title bar takes an icon and three buttons besides its text, often in a larger bold
    font: the dialog must be at least that wide, or the window manager cuts the title.
    """
    window.select_muscle("corrugator_L")
    seen = {}

    def rename(dialog):
        font = QtGui.QFont(dialog.font())
        font.setBold(True)
        font.setPointSizeF(1.2 * font.pointSizeF())
        bar = dialog.style().pixelMetric(QtWidgets.QStyle.PM_TitleBarHeight)
        seen.update(title=dialog.windowTitle(), width=dialog.width(),
                    needed=QtGui.QFontMetrics(font).horizontalAdvance(dialog.windowTitle())
                    + 4 * bar)
        dialog.setTextValue("corrugator_left")
        dialog.accept()

    answer(rename)
    window.rename_dialog()
    assert seen["title"] == "Rename muscle"
    assert seen["width"] >= seen["needed"], seen
    assert "corrugator_left" in window.session.face.muscle_names


def test_the_raking_light_keeps_the_field_colours_in_the_app(window):
    """View > Raking light on a field: the colour-mapped skin takes the colour-keeping
    material (plotting.raking_colour_material); off again, the plain one.
    """
    from wrinkle_vis.plotting.scenes import raking_colour_material

    skin = window.skin_view.actors["skin"]
    assert (skin.prop.ambient, skin.prop.diffuse) == (0.0, 1.0)
    window.raking_action.trigger()
    skin = window.skin_view.actors["skin"]
    assert skin.prop.ambient == pytest.approx(raking_colour_material()["ambient"])
    window.field_box.setCurrentText("H")  # a rebuild under the raking light keeps it
    window.select_muscle("corrugator_L")
    skin = window.skin_view.actors["skin"]
    assert skin.prop.ambient == pytest.approx(raking_colour_material()["ambient"])
    window.raking_action.trigger()
    assert (skin.prop.ambient, skin.prop.diffuse) == (0.0, 1.0)


def test_the_app_shows_fields_and_parameters_by_their_symbols(window):
    """The field box, the parameter panel, the probe table and the scalar bar read the
    symbols from the core's descriptions; the field box still speaks keys.
    """
    box = window.field_box
    shown = [box.shownText(i) for i in range(box.count())]
    assert "λ (length factor)" in shown and "ε (compression rate)" in shown
    assert "W (wrinkle amplitude)" in shown and "w (periodic coordinate)" in shown
    assert len({s.casefold() for s in shown}) == len(shown)  # w and W apart
    window.select_muscle("corrugator_L")
    box.setCurrentText("eps")
    assert box.currentText() == "eps" and box.shownText() == "ε (compression rate)"
    assert window.session.field == "eps"
    bar = window.skin_view.scalar_bars["eps, corrugator_L"]
    assert bar.GetTitle().rstrip() == "ε, corrugator_L"
    form = window.param_form
    labels = [form.itemAt(i, form.ItemRole.LabelRole).widget().text()
              for i in range(form.rowCount())
              if form.itemAt(i, form.ItemRole.LabelRole) is not None]
    assert "Φ (deg)" in labels and "k₀" in labels and "λ_w" in labels
    header = [window.probe_table.verticalHeaderItem(i).text()
              for i in range(window.probe_table.rowCount())]
    assert header[:2] == ["λ", "γ"] and "ε" in header and "W (mm)" in header
