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
    """

    def __init__(self, parent=None):
        super().__init__(parent)
        self.curves: list[tuple[str, np.ndarray, np.ndarray]] = []
        self.duration_s = 0.0
        self.time_s = 0.0
        self.setMinimumHeight(110)

    def set_curves(self, curves, duration_s: float) -> None:
        """Show ``curves`` (from :func:`track_curves`) over ``duration_s`` seconds."""
        self.curves, self.duration_s = list(curves), float(duration_s)
        self.update()

    def set_time(self, t: float) -> None:
        """Move the time line to ``t`` seconds."""
        self.time_s = float(t)
        self.update()

    def paintEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        """Draw the curves, their labels and the time line."""
        painter = QtGui.QPainter(self)
        try:
            painter.fillRect(self.rect(), QtGui.QColor("white"))
            w, h = self.width() - 8, self.height() - 18
            span = self.duration_s or 1.0
            for k, (label, times, values) in enumerate(self.curves):
                colour = QtGui.QColor(_COLOURS[k % len(_COLOURS)])
                painter.setPen(QtGui.QPen(colour, 1.5))
                points = [QtCore.QPointF(4 + w * t / span, 4 + h * (1.0 - v))
                          for t, v in zip(times, values, strict=True)]
                painter.drawPolyline(QtGui.QPolygonF(points))
                painter.drawText(QtCore.QPointF(6 + 52 * k, h + 16), label)
            painter.setPen(QtGui.QPen(QtGui.QColor("black"), 1.0))
            x = 4 + w * min(max(self.time_s / span, 0.0), 1.0)
            painter.drawLine(QtCore.QPointF(x, 4), QtCore.QPointF(x, 4 + h))
        finally:
            painter.end()
