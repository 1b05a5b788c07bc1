"""The control panel: small controls, each bound to one attribute of a model.

- :class:`ControlPanel`: the expression and its intensity, the timeline (Play, the time,
  Reset), the field and the muscle, refinement and wireframe, the colour range and the
  skin model with the physical skin's material; each bound (:func:`~.binding.bind`) to
  the :class:`~.models.Document`, :class:`~.models.Display` or :class:`~.models.Playback`
  attribute it shows;
- :class:`ProbePanel`: the probed point's coordinates and every field there.

The muscle's parameters have a panel of their own, per type (:mod:`.parameters`).
"""

from __future__ import annotations

import numpy as np
from qtpy import QtCore, QtWidgets

from ..core.face import FIELD_NAMES
from ..core.fields import FRAME_FIELDS
from ..core.skin import SKIN_MODELS, SkinMaterial
from ..plotting.fields import field_info
from .binding import bind, show
from .fieldbox import FieldBox
from .parameters import error_label, field_label, parameter_box
from .session import TIMELINE_STEPS, SurfacePoint

__all__ = ["PLAIN", "PROBE_HINT", "TOTAL", "ControlPanel", "ProbePanel"]

TOTAL = "total"
#: The colour map box's entry for the field's own map, and the maps it offers beside.
OWN_CMAP = "field's own"
CMAPS = ("viridis", "cividis", "magma", "inferno", "RdBu_r", "PuOr_r", "twilight", "Reds",
         "gray")
PLAIN = "none"  # the field box's entry for plain skin (no field)
#: What the probe panel says before a point is probed.
PROBE_HINT = "Right-click the skin to probe a point"


class ControlPanel(QtWidgets.QWidget):
    """The view's controls (rows of a form), each bound to one model attribute.

    Parameters
    ----------
    window : MainWindow
        Whose models (``document``, ``display``, ``playback``) the controls show and set,
        and whose controllers act on them (``edits`` for the skin's material).
    """

    def __init__(self, window):
        super().__init__()
        self.window = window
        self.bindings = []
        self.form = form = QtWidgets.QFormLayout(self)
        form.setContentsMargins(0, 0, 0, 0)
        self._expression_rows(form)
        self._field_rows(form)
        self._range_rows(form)
        self._skin_rows(form)
        self._on_document("session")

    # ------------------------------------------------------------------ expression
    def _expression_rows(self, form: QtWidgets.QFormLayout) -> None:
        w = self.window
        doc = w.document
        self.expression_box = QtWidgets.QComboBox()
        self.bindings.append(bind(self.expression_box, self.expression_box.currentTextChanged,
                                  doc.set_expression, lambda: doc.session.expression,
                                  doc.changed, ("session", "performance")))
        form.addRow("Expression", self.expression_box)
        self.intensity_slider = QtWidgets.QSlider(QtCore.Qt.Horizontal)
        self.intensity_slider.setRange(0, 100)
        self.bindings.append(bind(
            self.intensity_slider, self.intensity_slider.valueChanged,
            lambda v: doc.set_intensity(v / 100), lambda: round(100 * doc.session.intensity),
            doc.changed, ("session",)))
        form.addRow("Intensity", self.intensity_slider)
        row = QtWidgets.QHBoxLayout()
        self.play_button = QtWidgets.QPushButton("Play")
        self.play_button.setCheckable(True)
        self.bindings.append(bind(self.play_button, self.play_button.toggled,
                                  lambda on: setattr(w.playback, "playing", bool(on)),
                                  lambda: w.playback.playing, w.playback.changed))
        w.playback.changed.connect(self._show_playing)
        self.time_slider = QtWidgets.QSlider(QtCore.Qt.Horizontal)
        self.time_slider.setRange(0, TIMELINE_STEPS)
        self.bindings.append(bind(
            self.time_slider, self.time_slider.valueChanged,
            lambda v: doc.set_time(v / TIMELINE_STEPS
                                   * doc.session.current_expression().duration_s),
            lambda: slider_for_time(doc.session, doc.session.time_s), doc.changed,
            ("session", "performance", "time")))
        self.reset_button = QtWidgets.QPushButton("Reset")
        self.reset_button.setToolTip("Physical skin: back to rest at t = 0")
        row.addWidget(self.play_button)
        row.addWidget(self.time_slider)
        row.addWidget(self.reset_button)
        form.addRow("Timeline", row)

    def _show_playing(self, _=None) -> None:
        self.play_button.setText("Pause" if self.window.playback.playing else "Play")

    # ------------------------------------------------------------------ field
    def _field_rows(self, form: QtWidgets.QFormLayout) -> None:
        w = self.window
        doc, display = w.document, w.display
        # symbols and names (w is not W); the frame's fields (fold_guard) after the muscles'
        self.field_box = FieldBox([*FIELD_NAMES, *FRAME_FIELDS], PLAIN)
        self.muscle_box = QtWidgets.QComboBox()
        self.bindings.append(bind(self.field_box, self.field_box.currentTextChanged,
                                  self._on_field, lambda: PLAIN if display.options.plain
                                  else doc.session.field, doc.changed,
                                  ("session", "muscles", "selection", "face")))
        display.changed.connect(self._show_plain)
        self.bindings.append(bind(self.muscle_box, self.muscle_box.currentTextChanged,
                                  self._on_field, lambda: doc.session.muscle or TOTAL,
                                  doc.changed, ("session", "muscles", "selection")))
        doc.changed.connect(self._on_document)
        form.addRow("Field", self.field_box)
        form.addRow("Muscle", self.muscle_box)
        row = QtWidgets.QHBoxLayout()
        self.refine_box = QtWidgets.QCheckBox("Refine adaptively")
        self.bindings.append(bind(self.refine_box, self.refine_box.toggled, doc.set_refine,
                                  lambda: doc.session.refine, doc.changed, ("session",)))
        self.wireframe_box = QtWidgets.QCheckBox("Wireframe")
        self.bindings.append(bind(self.wireframe_box, self.wireframe_box.toggled,
                                  lambda on: display.set(wireframe=bool(on)),
                                  lambda: display.options.wireframe, display.changed,
                                  ("wireframe",)))
        row.addWidget(self.refine_box)
        row.addWidget(self.wireframe_box)
        form.addRow("Mesh", row)

    def _on_document(self, what: str) -> None:
        """The choices follow the face: its expressions and its muscles."""
        s = self.window.document.session
        if what in ("session", "performance"):
            show_items(self.expression_box, list(s.face.expressions) + (
                [s.performance.name] if s.performance is not None else []), s.expression)
        if what in ("session", "muscles"):
            show_items(self.muscle_box, [TOTAL, *s.face.muscle_names], s.muscle or TOTAL)

    def _show_plain(self, what: str) -> None:
        if what == "plain":
            show(self.field_box, PLAIN if self.window.display.options.plain
                 else self.window.document.session.field)

    def _on_field(self, _=None) -> None:
        """The field or the muscle box changed: show that field of that muscle (plain skin:
        keep a field for the probe and a switch back; a field only a muscle has falls back
        to W with a word in the status bar).
        """
        w = self.window
        field = self.field_box.currentText()
        muscle = self.muscle_box.currentText()
        muscle = None if muscle in ("", TOTAL) else muscle
        plain = field == PLAIN
        if plain:
            field = w.document.session.field if muscle is not None else "W"
        elif muscle is None and not field_info(field).total:
            show(self.field_box, "W")
            w.statusBar().showMessage(
                f"{field} belongs to one muscle: choose the muscle first (in the Muscle box "
                f"or the list); only W has a total", 10000)
            field = "W"
        w.document.set_field(field, muscle)
        w.display.set(plain=plain)

    # ------------------------------------------------------------------ colour range
    def _range_rows(self, form: QtWidgets.QFormLayout) -> None:
        display = self.window.display
        row = QtWidgets.QHBoxLayout()
        self.range_box = QtWidgets.QComboBox()
        self.range_box.addItems(["automatic", "fixed"])
        self.range_box.setToolTip("Colour range of the field. automatic: each frame's own "
                                  "while paused, the whole ramp's while playing; fixed: "
                                  "min and max")
        self.bindings.append(bind(self.range_box, self.range_box.currentTextChanged,
                                  self._on_range_mode,
                                  lambda: "fixed" if display.options.clim else "automatic",
                                  display.changed, ("clim",)))
        row.addWidget(self.range_box)
        self.range_min = QtWidgets.QDoubleSpinBox()
        self.range_max = QtWidgets.QDoubleSpinBox()
        for i, (box, tip) in enumerate(((self.range_min, "lowest value of the colour map"),
                                        (self.range_max, "highest value of the colour map"))):
            box.setRange(-1e9, 1e9)
            box.setDecimals(6)
            box.setKeyboardTracking(False)
            box.setToolTip(tip)
            self.bindings.append(bind(box, box.valueChanged, self._on_range_value,
                                      _range_end(display, box, i), display.changed,
                                      ("clim",)))
            box.installEventFilter(self.window.undo_keys)
            row.addWidget(box)
        form.addRow("Colour range", row)
        self.range_error = error_label()
        form.addRow(self.range_error)
        self.cmap_box = QtWidgets.QComboBox()
        self.cmap_box.addItems([OWN_CMAP, *CMAPS])
        self.cmap_box.setToolTip("Colour map of the field (the field's own: diverging for a "
                                 "signed field, sequential else)")
        self.bindings.append(bind(self.cmap_box, self.cmap_box.currentTextChanged,
                                  lambda text: display.set(cmap=None if text == OWN_CMAP
                                                           else text),
                                  lambda: display.options.cmap or OWN_CMAP, display.changed,
                                  ("cmap",)))
        form.addRow("Colour map", self.cmap_box)
        display.changed.connect(self._show_range)
        self._show_range("clim")

    def _show_range(self, what: str) -> None:
        """Min and max can be edited while the range is fixed."""
        if what == "clim":
            fixed = self.window.display.options.clim is not None
            for box in (self.range_min, self.range_max):
                box.setEnabled(fixed)

    def _on_range_mode(self, mode: str) -> None:
        """Colour range automatic, or fixed at min and max (which start at the range shown)."""
        w = self.window
        self.range_error.setText("")
        try:
            w.display.set(clim=None if mode != "fixed" else
                          w.views.scalar_range() or w.document.session.colour_range())
        except ValueError as exc:  # nothing to span (a field that is 0 everywhere)
            self.range_error.setText(str(exc))
            show(self.range_box, "automatic")

    def _on_range_value(self, _=None) -> None:
        try:
            self.window.display.set(clim=(self.range_min.value(), self.range_max.value()))
        except ValueError as exc:
            self.range_error.setText(str(exc))  # the range in use stays
            return
        self.range_error.setText("")

    # ------------------------------------------------------------------ physical skin
    def _skin_rows(self, form: QtWidgets.QFormLayout) -> None:
        """The skin-model switch and the physical skin's material, one box per parameter
        that :class:`~wrinkle_vis.core.skin.SkinMaterial` declares (as the muscles' boxes
        are made from their types' declarations).
        """
        w = self.window
        doc = w.document
        self.skin_box = QtWidgets.QComboBox()
        self.skin_box.addItems(list(SKIN_MODELS))
        self.skin_box.setToolTip("geometric: the muscles' pulls, each frame on its own; "
                                 "physical: a simulated mass-spring skin bound to the skull "
                                 "(Play runs it in real time; still frames show its "
                                 "equilibrium)")
        self.bindings.append(bind(self.skin_box, self.skin_box.currentTextChanged,
                                  lambda m: w.edits.set_skin_model(m),
                                  lambda: doc.session.face.skin_model, doc.changed,
                                  ("session", "face", "muscles")))
        form.insertRow(form.rowCount() - 1, "Skin", self.skin_box)  # above the range error
        self.skin_group = QtWidgets.QGroupBox("Physical skin")
        skin_form = QtWidgets.QFormLayout(self.skin_group)
        self.skin_widgets: dict[str, QtWidgets.QAbstractSpinBox] = {}
        for spec in SkinMaterial.parameters():  # what the material declares (core.params)
            box = parameter_box(spec, doc.session.unit)
            box.setKeyboardTracking(False)
            box.installEventFilter(w.undo_keys)  # Ctrl+Z undoes the edit, not the typing
            self.bindings.append(bind(
                box, box.valueChanged,
                lambda v, name=spec.name: w.edits.set_material(name, v),
                lambda name=spec.name: getattr(doc.session.face.material, name),
                doc.changed, ("session", "face", "muscles", "material")))
            self.skin_widgets[spec.name] = box
            skin_form.addRow(spec.display, box)
        self.skin_error = error_label()
        skin_form.addRow(self.skin_error)
        # in the form, under the switch: a group box in no layout is a window of its own
        form.insertRow(form.rowCount() - 1, self.skin_group)
        doc.changed.connect(self._show_skin)
        self._show_skin("session")

    def show_material(self) -> None:
        """Show the face's material again (an edit of it was refused)."""
        for binding in self.bindings:
            if binding.widget in self.skin_widgets.values():
                binding.show_model()

    def _show_skin(self, what: str) -> None:
        """The material and Reset only on the physical skin."""
        if what in ("session", "face", "muscles"):
            physical = self.window.document.session.face.skin_model == "physical"
            self.skin_group.setVisible(physical)
            self.reset_button.setEnabled(physical)


def _range_end(display, box: QtWidgets.QDoubleSpinBox, end: int):
    """What range box ``end`` (0: min, 1: max) shows: the fixed range's, else its own."""
    return lambda: box.value() if display.options.clim is None else display.options.clim[end]


class ProbePanel(QtWidgets.QGroupBox):
    """The probed point: its coordinates at rest and now, and every field of the total and
    of each muscle that defines anything there (the selected muscle first).
    """

    def __init__(self, unit: str):
        super().__init__("Probe (right-click the skin)")
        box = QtWidgets.QVBoxLayout(self)
        self.label = QtWidgets.QLabel(PROBE_HINT)
        self.label.setWordWrap(True)
        self.label.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
        box.addWidget(self.label)
        self.table = QtWidgets.QTableWidget(len(FIELD_NAMES), 1)
        self.table.setHorizontalHeaderLabels(["total"])
        self.table.setVerticalHeaderLabels([field_label(f, unit) for f in FIELD_NAMES])
        self.table.setVerticalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        box.addWidget(self.table)
        self.fit()

    def show_values(self, session, where: SurfacePoint) -> dict:
        """Show the values of ``session``'s frame at rest point ``where``; returns them."""
        values = session.probe(where)
        rest, now = session.probe_position(where)
        unit = session.unit
        frame = "".join(f"\n{k}: {values['total'][k]:.3g}" for k in FRAME_FIELDS)
        self.label.setText(f"at rest ({_xyz(rest)}) {unit}\nnow ({_xyz(now)}) {unit}"
                           + frame)  # the frame's fields: where the fold guard acted
        muscles = [m for m in values if m != "total"]
        if session.muscle in muscles:
            muscles.remove(session.muscle)
            muscles.insert(0, session.muscle)
        table = self.table
        table.setColumnCount(1 + len(muscles))
        table.setHorizontalHeaderLabels(["total", *muscles])
        table.setVerticalHeaderLabels([field_label(f, unit) for f in FIELD_NAMES])
        for row, field in enumerate(FIELD_NAMES):
            for col, column in enumerate(["total", *muscles]):
                if column == "total" and field not in values["total"]:
                    text = ""  # no total of this field
                else:
                    v = values[column][field]
                    text = "undefined" if not np.isfinite(v) else f"{v:.5g}"
                table.setItem(row, col, QtWidgets.QTableWidgetItem(text))
        if session.muscle in muscles:
            font = table.horizontalHeaderItem(1).font()
            font.setBold(True)
            table.horizontalHeaderItem(1).setFont(font)
        table.resizeColumnsToContents()
        self.fit()
        return values

    def clear(self, unit: str) -> None:
        """Probe nothing: the table empties."""
        self.label.setText(PROBE_HINT)
        self.table.setColumnCount(1)
        self.table.setHorizontalHeaderLabels(["total"])
        self.table.setVerticalHeaderLabels([field_label(f, unit) for f in FIELD_NAMES])
        self.table.clearContents()
        self.fit()

    def fit(self) -> None:
        """Make the table as tall as its rows: all of them show, none scrolls."""
        table = self.table
        table.resizeRowsToContents()
        height = (table.horizontalHeader().sizeHint().height() + 2 * table.frameWidth()
                  + sum(table.rowHeight(r) for r in range(table.rowCount())))
        if table.horizontalScrollBar().isVisible() or table.columnCount() > 2:
            height += table.horizontalScrollBar().sizeHint().height()
        table.setFixedHeight(height)


def slider_for_time(session, t: float | None) -> int:
    """Timeline position of ``t`` (None, the peak: the middle of the plateau)."""
    ex = session.current_expression()
    if t is None:
        t = ex.onset_s + 0.5 * ex.hold_s
    return round(TIMELINE_STEPS * t / ex.duration_s) if ex.duration_s > 0 else 0


def show_items(box: QtWidgets.QComboBox, items: list[str], current: str) -> None:
    """Give combo box ``box`` these ``items`` with ``current`` chosen (no signal)."""
    with QtCore.QSignalBlocker(box):
        box.clear()
        box.addItems(items)
        box.setCurrentText(current)


def _xyz(point) -> str:
    """``(3,)`` as ``x, y, z`` with 4 significant digits."""
    return ", ".join(f"{float(x):.4g}" for x in point)
