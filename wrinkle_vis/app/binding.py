"""One control bound to one model attribute, both ways.

:func:`bind` connects a widget's change signal to a setter of the model, and the model's
``changed`` event back to the widget, which shows the model's value without emitting (a
:class:`QSignalBlocker`): no control needs a hand-placed "updating" guard, and a value
set by the model never comes back as an edit. As napari's layer controls do.

Beside it, two event filters every value control gets: Undo and Redo reach the window from
a spin box (:class:`UndoKeysToWindow`), and the wheel edits a control only once it has the
focus (:func:`guard_wheel`).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Iterable
from typing import Any

from qtpy import QtCore, QtGui, QtWidgets

from .models import Signal

__all__ = ["Binding", "UndoKeysToWindow", "bind", "guard_wheel", "show", "weak"]


def weak(method, *args, keep: int = 0):
    """A slot calling ``method(*args, *signal_args[:keep])`` while ``method``'s object lives.

    It holds the object weakly: a Qt connection or a VTK observer made with it keeps no
    window alive (a lambda or a bound method there would, out of the garbage collector's
    sight).
    """
    ref = weakref.WeakMethod(method)

    def slot(*signal_args):
        bound = ref()
        return None if bound is None else bound(*args, *signal_args[:keep])

    return slot


def show(widget: QtWidgets.QWidget, value: Any) -> None:
    """Show ``value`` in ``widget`` without emitting its change signals.

    A combo box shows the entry whose text (or, failing that, data) is ``value``; a
    check box or button is checked by it; a slider or spin box takes it as its value.
    """
    with QtCore.QSignalBlocker(widget):
        if isinstance(widget, QtWidgets.QComboBox):
            i = widget.findText(str(value)) if isinstance(value, str) else -1
            widget.setCurrentIndex(i if i >= 0 else widget.findData(value))
        elif isinstance(widget, (QtWidgets.QAbstractButton, QtGui.QAction)):
            widget.setChecked(bool(value))
        else:
            widget.setValue(value)


class Binding:
    """``widget`` shows ``get()`` whenever ``events`` names one of ``keys`` (all of them:
    ``keys=None``), and its ``signal`` calls ``set(value)``. The widget's connection
    holds the binding weakly: its owner keeps it (the controls keep their bindings).
    """

    def __init__(self, widget: QtWidgets.QWidget, signal, set: Callable[[Any], None],
                 get: Callable[[], Any], events: Signal, keys: Iterable[str] | None):
        self.widget, self.get, self.set = widget, get, set
        self.keys = None if keys is None else frozenset(keys)
        signal.connect(weak(self._edited, keep=1))
        events.connect(self._changed)
        self.show_model()

    def show_model(self) -> None:
        """Show the model's value now."""
        show(self.widget, self.get())

    def _edited(self, value: Any = None) -> None:
        self.set(value)

    def _changed(self, key: str) -> None:
        if self.keys is None or key in self.keys:
            self.show_model()


def bind(widget: QtWidgets.QWidget, signal, set: Callable[[Any], None],
         get: Callable[[], Any], events: Signal, keys: Iterable[str] | None = None
         ) -> Binding:
    """Bind ``widget`` to a model attribute both ways (see :class:`Binding`)."""
    return Binding(widget, signal, set, get, events, keys)


class UndoKeysToWindow(QtCore.QObject):
    """An event filter that lets Undo and Redo reach the window's actions from a spin box
    (whose line edit would take Ctrl+Z for its own text).
    """

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 (Qt's name)
        """Pass Undo and Redo on to the window."""
        if event.type() == QtCore.QEvent.ShortcutOverride and (
                event.matches(QtGui.QKeySequence.Undo)
                or event.matches(QtGui.QKeySequence.Redo)):
            event.ignore()  # not the box's: the shortcut goes to the window
            return True
        return False


class _WheelOnlyWhenFocused(QtCore.QObject):
    """An event filter that keeps the wheel from a value control without the focus: the
    event goes on, unhandled, to the control's parents (the scrolled panel scrolls).
    """

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 (Qt's name)
        if event.type() == QtCore.QEvent.Wheel and not obj.hasFocus():
            event.ignore()  # not the control's: Qt passes it on to its parent
            return True
        return False


def guard_wheel(root: QtWidgets.QWidget) -> None:
    """The wheel edits the value controls under ``root`` only once they have the focus
    (a click or Tab gives it; the wheel does not): over an unfocused one it scrolls the
    panel, so scrolling through the controls edits nothing.
    """
    guard = root.findChild(_WheelOnlyWhenFocused) or _WheelOnlyWhenFocused(root)
    kinds = (QtWidgets.QAbstractSpinBox, QtWidgets.QComboBox, QtWidgets.QAbstractSlider)
    for w in root.findChildren(QtWidgets.QWidget):
        if not isinstance(w, kinds) or isinstance(w, QtWidgets.QScrollBar):
            continue  # a scroll bar (the probe table's) scrolls
        w.setFocusPolicy(QtCore.Qt.StrongFocus)
        w.installEventFilter(guard)
