"""A small plot of a recorded track's channels beside the views, with the timeline's time.

Qt only draws here: the curves come from :func:`track_curves` (no Qt), the time from the
window's timeline.
"""

from __future__ import annotations

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets

from ..core.tracks import Track, TrackMapping

#: At most this many curves, the ones that reach highest.
MAX_CURVES = 8
#: A channel that never reaches this drives too little to plot.
MIN_PEAK = 0.02
_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
            "#17becf")


def track_curves(track: Track, mapping: TrackMapping,
                 muscles) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``[(label, (n,) times, (n,) values)]``: the channels that drive a muscle of
    ``muscles`` and reach :data:`MIN_PEAK`, highest first, at most :data:`MAX_CURVES`.
    """
    names = set(muscles)
    out = []
    for j, channel in enumerate(track.channels):
        values = track.values[:, j]
        if values.max() >= MIN_PEAK and names & set(mapping.drives(channel)):
            out.append((channel, track.times, values))
    out.sort(key=lambda c: -c[2].max())
    return out[:MAX_CURVES]


class TrackPlot(QtWidgets.QWidget):
    """The curves of :func:`track_curves` over the track's duration, 0 to 1, and a line at
    the time shown.

    The curves are drawn once into a pixmap (again when they or the widget's size change);
    a frame of playback moves only the time line: :meth:`set_time` asks Qt to repaint the
    strips under the old and the new line, and a paint copies the pixmap there and draws
    the line.
    """

    #: Half the width, in pixels, of the strip repainted round the time line.
    STRIP = 2

    def __init__(self, parent=None):
        super().__init__(parent)
        self.curves: list[tuple[str, np.ndarray, np.ndarray]] = []
        self.duration_s = 0.0
        self.time_s = 0.0
        self._layer: QtGui.QPixmap | None = None  # the curves at the widget's size
        self.setMinimumHeight(110)
        self.setAttribute(QtCore.Qt.WA_OpaquePaintEvent)  # the pixmap covers it all

    def set_curves(self, curves, duration_s: float) -> None:
        """Show ``curves`` (from :func:`track_curves`) over ``duration_s`` seconds."""
        self.curves, self.duration_s = list(curves), float(duration_s)
        self._layer = None
        self.update()

    def set_time(self, t: float) -> None:
        """Move the time line to ``t`` seconds (repaints the old and new line's strips)."""
        old = self.cursor_x()
        self.time_s = float(t)
        new = self.cursor_x()
        if round(old) != round(new):
            self.update(self._strip(old))
            self.update(self._strip(new))

    def cursor_x(self) -> float:
        """The time line's x in pixels: ``4 + w t / T`` with ``w`` the plot's width."""
        span = self.duration_s or 1.0
        return 4 + (self.width() - 8) * min(max(self.time_s / span, 0.0), 1.0)

    def _strip(self, x: float) -> QtCore.QRect:
        return QtCore.QRect(int(np.floor(x)) - self.STRIP, 0, 2 * self.STRIP + 1,
                            self.height())

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        """The curves are drawn again at the new size."""
        self._layer = None
        super().resizeEvent(event)

    def _curve_layer(self) -> QtGui.QPixmap:
        """The background, curves and labels at the widget's size (drawn when missing)."""
        if self._layer is not None:
            return self._layer
        ratio = self.devicePixelRatioF()
        layer = QtGui.QPixmap(self.size() * ratio)
        layer.setDevicePixelRatio(ratio)
        layer.fill(QtGui.QColor("white"))
        painter = QtGui.QPainter(layer)
        try:
            w, h = self.width() - 8, self.height() - 18
            span = self.duration_s or 1.0
            for k, (label, times, values) in enumerate(self.curves):
                colour = QtGui.QColor(_COLOURS[k % len(_COLOURS)])
                painter.setPen(QtGui.QPen(colour, 1.5))
                points = [QtCore.QPointF(4 + w * t / span, 4 + h * (1.0 - v))
                          for t, v in zip(times, values, strict=True)]
                painter.drawPolyline(QtGui.QPolygonF(points))
                painter.drawText(QtCore.QPointF(6 + 52 * k, h + 16), label)
        finally:
            painter.end()
        self._layer = layer
        return layer

    def paintEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        """Copy the curves where Qt asks and draw the time line."""
        painter = QtGui.QPainter(self)
        try:
            painter.drawPixmap(0, 0, self._curve_layer())  # clipped to the asked region
            painter.setPen(QtGui.QPen(QtGui.QColor("black"), 1.0))
            x = self.cursor_x()
            painter.drawLine(QtCore.QPointF(x, 4), QtCore.QPointF(x, self.height() - 14))
        finally:
            painter.end()
