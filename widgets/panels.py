"""Qt panels that edit one model object each (Qt only through qtpy)."""

from __future__ import annotations

from qtpy import QtCore, QtWidgets

__all__ = ["MuscleListPanel"]


class MuscleListPanel(QtWidgets.QWidget):
    """The face's muscles as a list, with buttons for the editing actions.

    Parameters
    ----------
    actions : sequence of QAction
        Shown as buttons under the list, in order (add, delete, duplicate...); an action
        with a menu becomes a drop-down button.

    Signals
    -------
    selected(str)
        The user chose a muscle in the list ("" for none).
    """

    selected = QtCore.Signal(str)

    def __init__(self, actions=(), parent=None):
        super().__init__(parent)
        box = QtWidgets.QVBoxLayout(self)
        box.setContentsMargins(0, 0, 0, 0)
        self.list = QtWidgets.QListWidget()
        self.list.setSelectionMode(QtWidgets.QAbstractItemView.SingleSelection)
        self.list.currentTextChanged.connect(self._on_current)
        box.addWidget(self.list)
        row = QtWidgets.QHBoxLayout()
        self.buttons = {}
        for action in actions:
            button = QtWidgets.QToolButton()
            button.setDefaultAction(action)
            if action.menu() is not None:
                button.setPopupMode(QtWidgets.QToolButton.InstantPopup)
            row.addWidget(button)
            self.buttons[action.text().replace("&", "").rstrip(".")] = button
        row.addStretch(1)
        box.addLayout(row)
        self._quiet = False

    def set_muscles(self, names, current: str | None) -> None:
        """Show ``names`` with ``current`` selected (None: no selection); emits nothing."""
        self._quiet = True
        try:
            self.list.clear()
            self.list.addItems(list(names))
            self.set_current(current)
        finally:
            self._quiet = False

    def set_current(self, name: str | None) -> None:
        """Select ``name`` (None: nothing) without emitting :attr:`selected`."""
        quiet, self._quiet = self._quiet, True
        try:
            items = self.list.findItems(name, QtCore.Qt.MatchExactly) if name else []
            if items:
                self.list.setCurrentItem(items[0])
            else:
                self.list.setCurrentRow(-1)
                self.list.clearSelection()
        finally:
            self._quiet = quiet

    def current(self) -> str | None:
        """The selected muscle's name, or None."""
        item = self.list.currentItem()
        return item.text() if item is not None and item.isSelected() else None

    def _on_current(self, text: str) -> None:
        if not self._quiet:
            self.selected.emit(text)
