"""The app's dialogs: the view image's size, the guide, the keyboard shortcuts, and small
dialogs sized so that a window manager shows their whole title.
"""

from __future__ import annotations

from pathlib import Path

from qtpy import QtGui, QtWidgets

from .views import VIEWS

__all__ = ["GUIDE", "HelpController", "ImageDialog", "TextDialog", "ask_text", "fit_title",
           "title_width"]

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "guide.md"  # in a source checkout


class HelpController:
    """Help > Guide and Help > Keyboard shortcuts of ``window`` (read from its menus)."""

    def __init__(self, window):
        self.window = window
        self.guide_dialog = self.shortcuts_dialog = None

    def close(self) -> None:
        """Close the dialogs shown."""
        for dialog in (self.guide_dialog, self.shortcuts_dialog):
            if dialog is not None:
                dialog.close()

    def show_guide(self) -> QtWidgets.QDialog:
        """Show the user guide (``docs/guide.md``) in a window of its own."""
        if self.guide_dialog is None:
            self.guide_dialog = TextDialog(self.window, "wrinkle-vis guide", _guide_text(),
                                           GUIDE.parent)
        self.guide_dialog.show()
        self.guide_dialog.raise_()
        return self.guide_dialog

    def shortcuts(self) -> list[tuple[str, str, str]]:
        """``(menu, action, shortcut)`` of every action of the menus that has a shortcut,
        read from the actions themselves.
        """
        rows = []

        def walk(menu: QtWidgets.QMenu, where: str) -> None:
            for action in menu.actions():
                text = action.text().replace("&", "").rstrip(".")
                if action.menu() is not None:
                    walk(action.menu(), f"{where} > {text}")
                elif not action.isSeparator() and not action.shortcut().isEmpty():
                    rows.append((where, text, action.shortcut().toString(
                        QtGui.QKeySequence.NativeText)))

        for top in self.window.menuBar().actions():
            if top.menu() is not None:
                walk(top.menu(), top.text().replace("&", ""))
        return rows

    def show_shortcuts(self) -> QtWidgets.QDialog:
        """Show every action's shortcut (:meth:`shortcuts`) in a table."""
        dialog = self.shortcuts_dialog
        if dialog is None:
            dialog = self.shortcuts_dialog = QtWidgets.QDialog(self.window)
            dialog.setWindowTitle("Keyboard shortcuts")
            box = QtWidgets.QVBoxLayout(dialog)
            dialog.table = QtWidgets.QTableWidget(0, 3)
            dialog.table.setHorizontalHeaderLabels(["menu", "action", "shortcut"])
            dialog.table.verticalHeader().setVisible(False)
            dialog.table.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
            box.addWidget(dialog.table)
            note = QtWidgets.QLabel("Mouse: drag to rotate, wheel to zoom, right-click the "
                                    "skin to probe, click a muscle to select it, drag a "
                                    "handle to move it.")
            note.setWordWrap(True)
            box.addWidget(note)
            dialog.resize(560, 520)
        rows = self.shortcuts()  # built afresh: the recent files and plug-ins may change
        dialog.table.setRowCount(len(rows))
        for i, row in enumerate(rows):
            for j, text in enumerate(row):
                dialog.table.setItem(i, j, QtWidgets.QTableWidgetItem(text))
        dialog.table.resizeColumnsToContents()
        dialog.show()
        dialog.raise_()
        return dialog


class ImageDialog(QtWidgets.QDialog):
    """Which view to save as an image, and at what size in pixels."""

    def __init__(self, parent, size: tuple[int, int]):
        super().__init__(parent)
        self.setWindowTitle("Save view image")
        form = QtWidgets.QFormLayout(self)
        self.view_box = QtWidgets.QComboBox()
        self.view_box.addItems(list(VIEWS))
        form.addRow("View", self.view_box)
        self.width_box, self.height_box = QtWidgets.QSpinBox(), QtWidgets.QSpinBox()
        for box, value in ((self.width_box, size[0]), (self.height_box, size[1])):
            box.setRange(16, 8192)
            box.setSuffix(" px")
            box.setValue(int(value))
        form.addRow("Width", self.width_box)
        form.addRow("Height", self.height_box)
        form.addRow(QtWidgets.QLabel("Without the handles, the outlines and the probe."))
        buttons = QtWidgets.QDialogButtonBox(
            QtWidgets.QDialogButtonBox.Ok | QtWidgets.QDialogButtonBox.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)

    def view(self) -> str:
        """The chosen view."""
        return self.view_box.currentText()

    def size(self) -> tuple[int, int]:  # noqa: D102 (shadows QWidget.size on purpose)
        return self.width_box.value(), self.height_box.value()


class TextDialog(QtWidgets.QDialog):
    """A window showing Markdown text (the guide), images found beside it."""

    def __init__(self, parent, title: str, markdown: str, folder: Path):
        super().__init__(parent)
        self.setWindowTitle(title)
        box = QtWidgets.QVBoxLayout(self)
        self.browser = QtWidgets.QTextBrowser()
        self.browser.setSearchPaths([str(folder)])
        self.browser.setOpenExternalLinks(True)
        self.browser.setMarkdown(markdown)
        box.addWidget(self.browser)
        self.resize(820, 760)


def _guide_text() -> str:
    """The user guide, or where to find it when this install has no copy."""
    try:
        return GUIDE.read_text(encoding="utf-8")
    except OSError:
        return ("# wrinkle-vis guide\n\nThe guide is `docs/guide.md` in the wrinkle-vis "
                "source; this installation has no copy. Help > Keyboard shortcuts lists "
                "every action.")


#: A title bar's font is often bold and larger than the dialog's: this much larger.
TITLE_FONT_SCALE = 1.25
#: Room a title bar takes besides its text, in title-bar heights: an icon, three buttons
#: (minimise, maximise, close) and the padding around them.
TITLE_BAR_EXTRA = 5


def title_width(dialog: QtWidgets.QWidget) -> int:
    """The width, in pixels, ``dialog`` needs for a title bar that shows its whole title:
    the title in a bold font :data:`TITLE_FONT_SCALE` times larger than the dialog's, plus
    :data:`TITLE_BAR_EXTRA` title-bar heights for the bar's icon and buttons.
    """
    font = QtGui.QFont(dialog.font())
    font.setBold(True)
    if font.pointSizeF() > 0:
        font.setPointSizeF(TITLE_FONT_SCALE * font.pointSizeF())
    else:
        font.setPixelSize(round(TITLE_FONT_SCALE * font.pixelSize()))
    bar = dialog.style().pixelMetric(QtWidgets.QStyle.PM_TitleBarHeight)
    return QtGui.QFontMetrics(font).horizontalAdvance(dialog.windowTitle()) \
        + TITLE_BAR_EXTRA * bar


def fit_title(dialog: QtWidgets.QInputDialog) -> None:
    """Widen ``dialog`` to :func:`title_width`, so that its title is not cut short: its
    text box is made that wide less the layout's margins (the dialog's layout sets the
    dialog's size from its contents, over any minimum width set on the dialog itself).
    """
    margins = dialog.layout().contentsMargins() if dialog.layout() else None
    frame = margins.left() + margins.right() if margins is not None else 0
    edit = dialog.findChild(QtWidgets.QLineEdit)
    target = edit if edit is not None else dialog
    target.setMinimumWidth(max(target.minimumWidth(), title_width(dialog) - frame))


def ask_text(parent: QtWidgets.QWidget, title: str, label: str,
             text: str = "") -> tuple[str, bool]:
    """As :meth:`QInputDialog.getText`, in a dialog wide enough for its title: returns
    ``(text, accepted)``.
    """
    dialog = QtWidgets.QInputDialog(parent)
    dialog.setWindowTitle(title)
    dialog.setLabelText(label)
    dialog.setTextValue(text)
    fit_title(dialog)
    try:
        accepted = dialog.exec() == QtWidgets.QDialog.Accepted
        return dialog.textValue(), accepted
    finally:
        dialog.deleteLater()
