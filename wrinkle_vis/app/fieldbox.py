"""The Field box: the fields of the catalogue shown by their symbols and names, known by
their keys.
"""

from __future__ import annotations

from collections.abc import Sequence

from qtpy import QtCore, QtWidgets

from ..core.fields import field_spec

__all__ = ["FieldBox"]


class FieldBox(QtWidgets.QComboBox):
    """A combo box of the fields ``keys`` (:data:`~wrinkle_vis.core.fields.FIELDS`) and
    ``plain`` (no field), each entry showing :attr:`FieldSpec.display <wrinkle_vis.core.
    fields.FieldSpec.display>` (``λ (length factor)``, ``W (wrinkle amplitude)``,
    ``w (periodic coordinate)``) and its meaning as a tooltip.

    Its text methods speak keys, as a box of keys would: :meth:`currentText` is the key of
    the entry shown, :meth:`setCurrentText` shows the entry of a key and :meth:`itemText`
    gives an entry's key (what the entries show is :meth:`shownText`).
    """

    def __init__(self, keys: Sequence[str], plain: str,
                 plain_tip: str = "Plain skin, no field (try View > Raking light)"):
        super().__init__()
        for key in keys:
            spec = field_spec(key)
            self.addItem(spec.display, key)
            self.setItemData(self.count() - 1, f"{spec.symbol}: {spec.name}, {spec.meaning} "
                             f"({spec.equation})", QtCore.Qt.ToolTipRole)
        self.addItem(plain, plain)
        self.setItemData(self.count() - 1, plain_tip, QtCore.Qt.ToolTipRole)

    def currentText(self) -> str:  # noqa: N802 (Qt's name)
        """The key of the entry shown."""
        key = self.currentData()
        return super().currentText() if key is None else str(key)

    def setCurrentText(self, key: str) -> None:  # noqa: N802 (Qt's name)
        """Show the entry of ``key`` (an unknown key changes nothing)."""
        index = self.findData(key)
        if index >= 0:
            self.setCurrentIndex(index)

    def itemText(self, index: int) -> str:  # noqa: N802 (Qt's name)
        """The key of entry ``index``."""
        key = self.itemData(index)
        return super().itemText(index) if key is None else str(key)

    def shownText(self, index: int | None = None) -> str:  # noqa: N802 (Qt's style)
        """What entry ``index`` (default the current one) shows."""
        return super().itemText(self.currentIndex() if index is None else index)
