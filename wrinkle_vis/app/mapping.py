"""Edit > Track mapping...: which muscles each channel of a recorded track drives, as a
table of weights (channels down, the face's muscles across), edited as one undoable step.

The weights and their checks are core's (:class:`~wrinkle_vis.core.tracks.TrackMapping`,
:class:`~wrinkle_vis.core.tracks.ChannelMap`); this module only shows them. The mapping is
the face's (its layout's ``"mapping"``, saved with it); a track playing in the window is
played again through the edited mapping (:meth:`Performance.remapped
<wrinkle_vis.core.tracks.Performance.remapped>`, from the session), and the track plot
shows the channels that now drive a muscle.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets

from ..core.tracks import ChannelMap, TrackMapping, default_mapping
from .trackplot import track_curves

#: The edit's name in the undo history.
EDIT_TEXT = "Edit the track mapping"


def mapping_table(mapping: TrackMapping, muscles: Sequence[str]
                  ) -> tuple[list[str], list[str], np.ndarray]:
    """``(channels, muscles, (C, M) weights)``: ``mapping``'s weights on ``muscles`` (the
    face's, in order), 0 where a channel does not drive a muscle; channels in the
    mapping's order.
    """
    channels = list(mapping.channels)
    muscles = list(muscles)
    weights = np.zeros((len(channels), len(muscles)))
    column = {m: j for j, m in enumerate(muscles)}
    for i, name in enumerate(channels):
        for m, w in mapping.channels[name].muscles.items():
            if m in column:
                weights[i, column[m]] = w
    return channels, muscles, weights


def mapping_from_table(base: TrackMapping, channels: Sequence[str], muscles: Sequence[str],
                       weights: np.ndarray) -> TrackMapping:
    """``base`` with the weights of ``muscles`` set from ``weights`` ``(C, M)`` (0: the
    channel does not drive the muscle); each channel keeps its response curve and the
    weights of muscles not in ``muscles``. ``ValueError``, one line naming the channel, for
    a weight :class:`~wrinkle_vis.core.tracks.ChannelMap` refuses.
    """
    shown = set(muscles)
    out = {}
    for i, name in enumerate(channels):
        old = base.channels.get(name, ChannelMap())
        kept = {m: w for m, w in old.muscles.items() if m not in shown}
        kept.update({m: float(w) for m, w in zip(muscles, weights[i], strict=True) if w != 0})
        try:
            out[name] = ChannelMap(kept, old.curve)
        except ValueError as exc:
            raise ValueError(f"channel {name}: {exc}") from None
    return TrackMapping(out)


def parse_weight(text: str, muscle: str) -> float:
    """A cell's weight of ``muscle``: a number in ``[0, 1]`` (empty: 0), as
    :class:`~wrinkle_vis.core.tracks.ChannelMap` checks it. ``ValueError``, one line.
    """
    text = text.strip()
    if not text:
        return 0.0
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a number; give a weight from 0 to 1") from None
    try:
        ChannelMap({muscle: value})  # core's check
    except ValueError as exc:
        raise ValueError(f"{exc}; give a weight from 0 to 1") from None
    return value


class MappingDialog(QtWidgets.QDialog):
    """The table of weights of a mapping on a face's muscles, with OK and Cancel.

    A cell takes a weight from 0 to 1 (empty: 0); a bad one is refused with its reason in
    one line under the table and the cell put back. :meth:`mapping` is the edited mapping.
    """

    def __init__(self, mapping: TrackMapping, muscles: Sequence[str], parent=None):
        super().__init__(parent)
        self.setWindowTitle("Track mapping")
        self.base = mapping
        self.channels, self.muscles, self.weights = mapping_table(mapping, muscles)
        self.table = QtWidgets.QTableWidget(len(self.channels), len(self.muscles))
        self.table.setHorizontalHeaderLabels(self.muscles)
        self.table.setVerticalHeaderLabels(self.channels)
        for i in range(len(self.channels)):
            for j in range(len(self.muscles)):
                self.table.setItem(i, j, QtWidgets.QTableWidgetItem(_text(self.weights[i, j])))
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.DoubleClicked
                                   | QtWidgets.QAbstractItemView.EditKeyPressed
                                   | QtWidgets.QAbstractItemView.AnyKeyPressed)
        self.table.cellChanged.connect(self._on_cell)
        self.error = QtWidgets.QLabel()
        self.error.setStyleSheet("color: #b00020")
        self.buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.Ok
                                                  | QtWidgets.QDialogButtonBox.Cancel)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(QtWidgets.QLabel(
            "Weight of each muscle (across) for each channel of a track (down), 0 to 1; "
            "a muscle's activation is the sum of weight x response over the channels, "
            "clipped to [0, 1]"))
        layout.addWidget(self.table)
        layout.addWidget(self.error)
        layout.addWidget(self.buttons)
        self.resize(900, 600)

    def _on_cell(self, i: int, j: int) -> None:
        item = self.table.item(i, j)
        try:
            value = parse_weight(item.text(), self.muscles[j])
        except ValueError as exc:
            self.error.setText(f"{self.channels[i]} -> {self.muscles[j]}: {exc}")
            value = self.weights[i, j]
        else:
            self.error.setText("")
            self.weights[i, j] = value
        self.table.blockSignals(True)
        item.setText(_text(value))
        self.table.blockSignals(False)

    def mapping(self) -> TrackMapping:
        """The mapping with the table's weights."""
        return mapping_from_table(self.base, self.channels, self.muscles, self.weights)


def _text(w: float) -> str:
    return "" if w == 0 else f"{w:g}"


def open_mapping_dialog(window) -> MappingDialog:
    """Show the face's mapping in a :class:`MappingDialog` (window-modal, not blocking);
    OK applies it as one undoable edit (:data:`EDIT_TEXT`) when it changed.
    """
    face = window.session.face
    dialog = MappingDialog(face.mapping or default_mapping(), face.muscle_names, window)
    dialog.setAttribute(QtCore.Qt.WA_DeleteOnClose)
    ref = weakref.ref(window)

    def apply() -> None:
        w = ref()
        if w is None:
            return
        new, now = dialog.mapping(), w.session.face
        if new != (now.mapping or default_mapping()):
            w.edit(EDIT_TEXT, now.with_mapping(new))

    dialog.accepted.connect(apply)
    window.mapping_dialog = dialog
    dialog.open()
    return dialog


def show_track_channels(window) -> None:
    """Plot the channels of the track playing that drive a muscle through its mapping."""
    perf = window.session.performance
    plot = getattr(window, "track_plot", None)
    if plot is None or perf is None or perf.track is None:
        return
    curves = track_curves(perf.track, perf.mapping or default_mapping(),
                          window.session.face.muscle_names)
    plot.set_curves(curves, perf.track.duration_s)


def add_mapping_action(window, menu: QtWidgets.QMenu) -> QtGui.QAction:
    """Edit > Track mapping... in ``menu``; the track plot follows the mapping's edits, undos
    and redos.
    """
    ref = weakref.ref(window)
    action = menu.addAction("Track &mapping...")
    action.setToolTip("Which muscles each channel of a recorded track drives, and how much")
    action.triggered.connect(lambda: ref() is not None and open_mapping_dialog(ref()))
    window.undo_stack.indexChanged.connect(
        lambda _: ref() is not None and show_track_channels(ref()))
    return action
