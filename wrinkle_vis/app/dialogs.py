"""Small dialogs of the app, sized so that a window manager shows their whole title."""

from __future__ import annotations

from qtpy import QtGui, QtWidgets

__all__ = ["ask_text", "fit_title", "title_width"]

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
