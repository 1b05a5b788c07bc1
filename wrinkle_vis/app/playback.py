"""Play: a timer that moves the timeline (or runs the physical skin's simulation) while
the :class:`~.models.Playback` model says ``playing``.
"""

from __future__ import annotations

import time

from qtpy import QtCore

from .binding import weak
from .session import playback_position

__all__ = ["PLAY_TICK_MS", "PlaybackController"]

PLAY_TICK_MS = 16  # Play's timer: at most about 60 frames a second


class PlaybackController:
    """Play and pause of ``window``'s document, and the physical skin's Reset."""

    def __init__(self, window):
        self.window = window
        self.timer = QtCore.QTimer(window)  # Play: ticks as fast as 60 a second
        self.timer.setInterval(PLAY_TICK_MS)
        self.timer.timeout.connect(weak(self.tick))
        self.clock = time.perf_counter  # the physical skin's wall clock (tests fake it)
        window.playback.changed.connect(self._on_playing)
        window.document.changed.connect(self._on_document)

    def _on_playing(self, _=None) -> None:
        w = self.window
        s = w.document.session
        if w.playback.playing:
            w.playback.start = (w.controls.time_slider.value(), time.perf_counter())
            if s.face.skin_model == "physical":
                self._play_physical()
                w.document.simulation_changed()
            self.timer.start()
        else:
            self.timer.stop()
            s.pause()  # a simulation keeps its state

    def _on_document(self, what: str) -> None:
        """The performance's plot follows the time."""
        plot = self.window.files.track_plot
        if plot is not None and what in ("frame", "time"):
            plot.set_time(self.window.document.session.time_s)

    def tick(self) -> None:
        """Play: move the timeline to where the expression is now (a frame is drawn when
        the position changes; one that took long skips positions).
        """
        w = self.window
        s = w.document.session
        if s.face.skin_model == "physical":
            self._tick_physical()
            return
        start, t0 = w.playback.start
        ex = s.current_expression()
        w.controls.time_slider.setValue(playback_position(start, time.perf_counter() - t0,
                                                          ex.duration_s))

    def _tick_physical(self) -> None:
        """Play on the physical skin: advance the simulation by the wall-clock time since
        the last tick (:meth:`PhysicalPlayback.tick`) and draw it if it moved.
        """
        s = self.window.document.session
        if not s.physics.playing:  # switched to the physical skin, or a layout opened
            self._play_physical()
        if s.tick(self.clock()):
            self.window.document.simulation_changed()

    def _play_physical(self) -> None:
        """Play the physical skin's simulation (starting one if none runs) and follow the
        wall clock from when it is ready (:meth:`PhysicalPlayback.sync`): the time the
        start took is not simulated at the first tick.
        """
        s = self.window.document.session
        s.play(self.clock())
        s.physics.sync(self.clock())

    def reset_simulation(self) -> None:
        """Physical skin: back to rest at t = 0 (playing on if playing)."""
        s = self.window.document.session
        if s.face.skin_model != "physical":
            return
        s.reset_simulation()
        self.window.document.simulation_changed()
