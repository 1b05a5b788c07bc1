"""The selected muscle's parameter panel, per muscle type, built from what the type declares.

A muscle type brings its own panel the way it brings its placement widget
(:func:`wrinkle_vis.widgets.widget_factory`): it declares ``panel = "package.module:Class"``
on its class, or one is registered for it with :func:`register_panel`; a type with none
gets :class:`ParameterPanel`, one box per number the type declares
(:meth:`~wrinkle_vis.core.muscle.Muscle.parameters`, with the metadata's label, unit,
range and step) and one check box or combo box per option. A panel class takes
``(muscle, unit, edits)`` and has the attributes and methods of :class:`ParameterPanel`.
"""

from __future__ import annotations

import math
import re

import numpy as np
from qtpy import QtCore, QtWidgets

from ..core.registry import TypeLookup
from ..core.units import LENGTH_UNITS
from ..plotting.fields import field_info
from .binding import guard_wheel, show, weak
from .session import editable

__all__ = ["ParameterGroup", "ParameterPanel", "error_label", "field_label", "panel_factory",
           "parameter_box", "register_panel", "show_value"]


class ParameterPanel(QtWidgets.QWidget):
    """The parameters, the options and the activation of one muscle (None: a hint to
    choose one), with the reason under them when an edit is refused.

    Parameters
    ----------
    muscle : Muscle or None
        The muscle shown.
    unit : str
        The face's length unit (the boxes' steps and digits follow it).
    edits : EditController
        Where an edit goes: ``edits.set_parameter(name, value)`` and
        ``edits.set_activation(value)`` (held weakly).
    """

    def __init__(self, muscle, unit: str, edits):
        super().__init__()
        self.muscle = muscle
        self.form = QtWidgets.QFormLayout(self)
        self.form.setContentsMargins(0, 0, 0, 0)
        self.error = error_label()
        self.widgets: dict[str, QtWidgets.QAbstractSpinBox] = {}
        self.option_widgets: dict[str, QtWidgets.QWidget] = {}  # a QCheckBox or a QComboBox
        self.activation_box = self.derived_label = None
        self._edit = weak(edits.set_parameter, keep=2)
        if muscle is None:
            self.form.addRow(QtWidgets.QLabel("Choose a muscle to edit it."))
            return
        for spec in editable(muscle):  # what the type declares (core.params)
            box = parameter_box(spec, unit)
            show_value(box, muscle.resolved(spec.name))
            box.setKeyboardTracking(False)
            box.valueChanged.connect(weak(edits.set_parameter, spec.name, keep=1))
            self.widgets[spec.name] = box
            self.form.addRow(spec.display, box)
        for spec in muscle.options():  # every type has them, declared in core.muscle
            self.option_widgets[spec.name] = self._option_control(spec, muscle)
            self.form.addRow(spec.display, self.option_widgets[spec.name])
        self.activation_box = QtWidgets.QDoubleSpinBox()
        self.activation_box.setRange(0.0, 1.0)
        self.activation_box.setSingleStep(0.05)
        self.activation_box.setKeyboardTracking(False)
        self.activation_box.setToolTip(
            "The muscle's peak activation in the expression shown: an edit of the layout "
            "(undoable, saved with it); 0 takes the muscle out of the expression")
        self.activation_box.valueChanged.connect(weak(edits.set_activation, keep=1))
        self.form.addRow("activation", self.activation_box)
        self.derived_label = QtWidgets.QLabel()
        self.form.addRow("derived", self.derived_label)
        self.form.addRow(self.error)

    def _option_control(self, spec, muscle) -> QtWidgets.QWidget:
        """A check box for a flag, else a combo box of the option's labelled choices."""
        if spec.is_flag:
            box = QtWidgets.QCheckBox()
            box.toggled.connect(weak(self._on_option, spec.name, keep=1))
        else:
            box = QtWidgets.QComboBox()
            for value, text in spec.labelled_choices.items():
                box.addItem(text, value)
            box.currentIndexChanged.connect(weak(self._on_option, spec.name, keep=1))
        box.setToolTip(spec.doc)
        show(box, getattr(muscle, spec.name))
        return box

    def _on_option(self, param: str, value) -> None:
        """An option's check box (bool) or combo box (an index) changed."""
        box = self.option_widgets[param]
        if isinstance(box, QtWidgets.QComboBox):
            self._edit(param, box.itemData(value))
        else:
            self._edit(param, bool(value))

    def show_muscle(self, muscle, activation: float, derived: str) -> None:
        """Show ``muscle``'s values (of the same type) in place, without emitting."""
        self.muscle = muscle
        for param, box in self.widgets.items():
            with QtCore.QSignalBlocker(box):
                show_value(box, muscle.resolved(param))
        for param, box in self.option_widgets.items():
            show(box, getattr(muscle, param))
        self.show_activation(activation)
        self.show_derived(derived)

    def put_back(self, param: str) -> None:
        """Show the muscle's value of ``param`` again (an edit of it was refused)."""
        if param in self.option_widgets:
            show(self.option_widgets[param], getattr(self.muscle, param))
        elif param in self.widgets:
            with QtCore.QSignalBlocker(self.widgets[param]):
                show_value(self.widgets[param], self.muscle.resolved(param))

    def show_activation(self, value: float) -> None:
        """Show the muscle's peak activation in the expression (no signal)."""
        if self.activation_box is not None:
            show(self.activation_box, value)

    def show_derived(self, text: str) -> None:
        """Show the derived quantities (``d = ...  u = ...``)."""
        if self.derived_label is not None:
            self.derived_label.setText(text)

    def labels(self) -> dict[str, str]:
        """The muscle's parameters as the panel labels them."""
        if self.muscle is None:
            return {}
        return {p.name: p.display for p in (*editable(self.muscle), *self.muscle.options())}

    def labelled(self, message: str) -> str:
        """``message`` with the parameters called by the labels the panel shows them under
        (``parameter max_angle_deg = 95`` -> ``Φ (deg) = 95``).
        """
        labels = self.labels()
        message = re.sub(r"\bparameter (\w+) =",
                         lambda m: f"{labels.get(m.group(1), m.group(1))} =", message)
        for param, label in labels.items():
            if "_" in param and param != label:  # a name no word of the prose has
                message = re.sub(rf"\b{param}\b", label, message)
        return message


#: The parameter panels by muscle type (:func:`register_panel`, :func:`panel_factory`).
_LOOKUP = TypeLookup("panel", ParameterPanel, "Class")


def panel_factory(muscle_type: type):
    """The parameter panel class for ``muscle_type``: registered for it or a base class,
    else declared as its ``panel`` attribute, else :class:`ParameterPanel`.
    """
    return _LOOKUP(muscle_type)


def register_panel(muscle_type: type, panel=None):
    """Use ``panel`` (a :class:`ParameterPanel` subclass) for ``muscle_type`` and its
    subclasses (usable as a decorator: ``@register_panel(MyMuscle)``).
    """
    return _LOOKUP.register(muscle_type, panel)


def error_label() -> QtWidgets.QLabel:
    """A red, wrapping label for the reason a value was refused."""
    label = QtWidgets.QLabel()
    label.setStyleSheet("color: #b00020")
    label.setWordWrap(True)
    return label


def field_label(field: str, unit: str) -> str:
    """A field's symbol with its unit: ``W (mm)``, ``λ``."""
    return field_info(field).display_label(unit)


def parameter_box(spec, unit: str) -> QtWidgets.QAbstractSpinBox:
    """A spin box for one declared parameter (:class:`~wrinkle_vis.core.params.Parameter`):
    whole numbers for a count, else three decimals (more for an SI unit with a small step,
    as the physical skin's thickness); its step from the metadata, and a
    tooltip with its symbol, meaning, unit and range. The box takes any value, so that one
    out of range is refused by the core with its reason, not clipped silently.
    """
    if spec.unit == "count":
        box = QtWidgets.QSpinBox()
        box.setRange(-999, 999)
        box.setSingleStep(max(1, int(spec.step)))
    elif spec.unit == "length":  # the step is in mm: steps and digits follow the unit
        mm = LENGTH_UNITS["mm"] / LENGTH_UNITS.get(unit, LENGTH_UNITS["mm"])
        box = QtWidgets.QDoubleSpinBox()
        box.setDecimals(3 + max(0, round(-np.log10(mm))))
        box.setRange(-1e6, 1e6)
        box.setSingleStep(spec.step * mm)
    elif spec.unit in ("1", "deg"):
        box = QtWidgets.QDoubleSpinBox()
        box.setDecimals(3)
        box.setRange(-1e6, 1e6)
        box.setSingleStep(spec.step)
    else:  # an SI unit (the physical skin's material): digits from the step
        box = QtWidgets.QDoubleSpinBox()
        box.setDecimals(max(3, 2 - math.floor(math.log10(spec.step))) if spec.step > 0
                        else 6)
        box.setRange(-1e12, 1e12)
        box.setSingleStep(spec.step)
    if isinstance(box, QtWidgets.QDoubleSpinBox):
        box.setProperty("base_decimals", box.decimals())
    shown = {"length": unit, "deg": "deg", "1": "", "count": ""}.get(spec.unit, spec.unit)
    derived = "; left out, derived from the others" if spec.optional else ""
    box.setToolTip(f"{spec.symbol}: {spec.doc}" + (f" ({shown})" if shown else "")
                   + f"; allowed {spec.range_text()}{derived}")
    return box


def show_value(box: QtWidgets.QAbstractSpinBox, value) -> None:
    """Show ``value`` in a parameter box whole: the box's own decimals, or as many more
    (up to 10) as the value needs not to be rounded, as the box rounds what it holds to
    its decimals (k0 = 0.02152 would read, and be, 0.022).
    """
    if isinstance(box, QtWidgets.QDoubleSpinBox):
        base = box.property("base_decimals")
        decimals = box.decimals() if base is None else int(base)
        while decimals < 10 and not np.isclose(round(value, decimals), value, rtol=1e-9,
                                                 atol=0.0):
            decimals += 1
        box.setDecimals(decimals)
    box.setValue(value)


class ParameterGroup(QtWidgets.QGroupBox):
    """The group box holding the selected muscle's panel (:func:`panel_factory` of its
    type), built again when another muscle or type is selected, else updated in place (an
    undo, a redo, a drag's step); the activation follows the expression shown.

    Parameters
    ----------
    window : MainWindow
        Its ``document`` (what to show), ``edits`` (where edits go) and ``undo_keys``
        (the boxes' Ctrl+Z undoes the edit, not the typing).
    """

    def __init__(self, window):
        super().__init__("Parameters of the selected muscle")
        self.window = window
        self.box = QtWidgets.QVBoxLayout(self)
        self.panel: ParameterPanel | None = None
        self._for = None
        window.document.changed.connect(self._on_document)
        self.build()

    def build(self) -> None:
        """A new panel for the selected muscle (or none)."""
        w = self.window
        s = w.document.session
        muscle = s.face.muscle(s.muscle) if s.muscle is not None else None
        self._for = None if muscle is None else (muscle.name, muscle.type_name)
        if self.panel is not None:
            self.box.removeWidget(self.panel)
            self.panel.setParent(None)
            self.panel.deleteLater()
        factory = ParameterPanel if muscle is None else panel_factory(type(muscle))
        self.panel = factory(muscle, s.unit, w.edits)
        self.box.addWidget(self.panel)
        for box in self.panel.findChildren(QtWidgets.QAbstractSpinBox):
            box.installEventFilter(w.undo_keys)
        self.show_activation()
        self.show_derived()
        guard_wheel(self)

    def _on_document(self, what: str) -> None:
        s = self.window.document.session
        if what in ("session", "muscles", "selection", "face"):
            muscle = s.face.muscle(s.muscle) if s.muscle is not None else None
            if muscle is None or self._for != (muscle.name, muscle.type_name):
                self.build()
            else:
                self.panel.show_muscle(muscle, self._activation(), self._derived())
        elif what == "frame":
            self.show_activation()

    def _activation(self) -> float:
        s = self.window.document.session
        return s.current_expression().activations.get(s.muscle, 0.0)

    def _derived(self) -> str:
        s = self.window.document.session
        d = s.derived(s.muscle)
        return f"d = {d['d']:.4g} {s.unit}   u = {d['u']:.4g} {s.unit}"

    def show_activation(self) -> None:
        """Show the selected muscle's peak activation in the expression shown."""
        if self.window.document.session.muscle is not None:
            self.panel.show_activation(self._activation())

    def show_derived(self) -> None:
        """Show the selected muscle's derived quantities."""
        if self.window.document.session.muscle is not None:
            self.panel.show_derived(self._derived())
