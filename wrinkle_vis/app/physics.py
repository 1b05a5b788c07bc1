r"""Play on the physically based skin: the simulation in real time, with no Qt in it.

On the geometric skin each frame of the timeline is evaluated on its own. On the physical
skin (:mod:`wrinkle_vis.core.skin`) a frame depends on the ones before it, so the app runs
one :class:`~wrinkle_vis.core.simulation.Simulation` and shows its state:

* **Still frames** (nothing played since the face, the expression, the intensity or the
  activations set by hand last changed): the equilibrium for the activations at the
  timeline's time, ``face.evaluate(..., skin="physical")``; no simulation.
* **Play** starts the simulation (from rest at :math:`t = 0`, re-simulated to the
  timeline's time as a scrub is) and each timer tick advances it by the wall-clock time
  elapsed since the last tick (:meth:`PhysicalPlayback.tick`): simulated time follows the
  wall clock, from when the simulation is ready (:meth:`PhysicalPlayback.sync`: the time
  the start took is not simulated). The steps are the material's ``time_step``
  :math:`h` (the matrix is factorized once per step size, so a step is never shortened);
  what is left of the elapsed time waits for the next tick. A tick takes at most
  :attr:`~PhysicalPlayback.max_steps` steps and drops the rest of the lag, so a slow frame
  slows the simulation down instead of making the next frame slower still. The command is
  the expression's timeline at the simulated time; past the end of the timeline the
  simulation starts again from rest at :math:`t = 0` (Play goes round and round, as on the
  geometric skin).
* **Pause** keeps the simulation's state (shown, and played on from, as it is).
* **Reset** puts the skin back to rest at :math:`t = 0`.
* **Scrubbing** the timeline while a simulation runs (playing or paused) re-simulates up
  to the time chosen, :math:`t`: the steps of the last :attr:`~PhysicalPlayback.history_s`
  seconds (0.5 s, 15 steps at :math:`h = 1/30` s) from rest at :math:`t = 0` when that is
  the whole timeline before :math:`t`, else from the still equilibrium at
  :math:`t - 0.5` s (the skin at rest, the muscles' activations at their commands there).
  Why not always from :math:`t = 0`: a step costs about 13 ms of CPU at paper size, so a
  scrub to the end of a 3 s expression would take more than a second, at every move of the
  slider. What the skin remembers from before :math:`t - 0.5` s is nothing the picture
  shows: the activations forget their past as :math:`e^{-\Delta t/\tau_a}` (:math:`\tau_a
  = 45` ms: :math:`e^{-11} \approx 10^{-5}` after 0.5 s) and the skin settles within
  milliseconds (:mod:`wrinkle_vis.core.skin`), so the state is that of the re-simulation
  from :math:`t = 0` to within :math:`10^{-3}` of its largest displacement (measured on
  surprise at paper size: 0.6·10⁻⁴ at 1 s, 0.3·10⁻⁴ at 1.5 s, 3·10⁻⁴ at 2.3 s; what is
  left is the solver's own tolerance; ``tests/test_app_physical.py``). A scrub costs about
  0.4 s of CPU at paper size (the equilibrium and 15 steps) and lands on the last step at
  or before :math:`t`.

While playing, changing the expression, the intensity or an activation changes the
command and the skin goes on from where it is; changing the face (a muscle, the skin's
material) starts a new simulation of the new face, re-simulated to the same time. While
not playing, any such change ends the simulation: the still frame shows again.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from ..core.face import FaceModel, FaceState
from ..core.simulation import Simulation

__all__ = ["PhysicalPlayback"]


class PhysicalPlayback:
    """The running simulation of a session's physical skin (module docstring).

    Parameters
    ----------
    timeline : callable ``t -> activations``
        The command: the expression's activations at ``t`` seconds, as the session shows
        them (intensity and activations set by hand applied).
    duration_s : callable ``() -> float``
        The timeline's length in seconds (0: a step held for ever).
    max_steps : int, default 3
        The most steps a tick takes (at :math:`h = 1/30` s, 0.1 s of lag).
    history_s : float, default 0.5
        How much of the timeline before the time chosen a scrub simulates (module
        docstring).

    Attributes
    ----------
    simulation : Simulation or None
        None: no simulation (still frames show the equilibrium).
    played_s : float
        The simulated seconds that ticks have advanced, in all: the steps taken times
        :math:`h`, however often the timeline went round (what a measure of real time
        divides by the wall-clock time; ``time`` restarts at the end of the timeline).
    dropped_s : float
        The wall-clock seconds that ticks left unsimulated (the lag over
        :attr:`max_steps` steps), in all: while playing, ``played_s + dropped_s`` is the
        wall-clock time since :meth:`play` (or :meth:`sync`) to within the lag, less than
        a step.
    """

    def __init__(self, timeline: Callable[[float], dict], duration_s: Callable[[], float],
                 max_steps: int = 3, history_s: float = 0.5):
        self._timeline = timeline
        self._duration_s = duration_s
        self.max_steps = int(max_steps)
        self.history_s = float(history_s)
        self.simulation: Simulation | None = None
        self._face: FaceModel | None = None
        self._clock: float | None = None  # the wall clock at the last tick (None: paused)
        self._lag = 0.0  # wall seconds elapsed and not simulated yet (less than a step)
        self.played_s = 0.0  # simulated seconds the ticks advanced, in all (steps times h)
        self.dropped_s = 0.0  # wall seconds left unsimulated by the cap, in all
        self.resimulated = False  # whether the last start simulated from rest at t = 0

    # ------------------------------------------------------------------ state
    @property
    def live(self) -> bool:
        """Whether a simulation runs (playing or paused), rather than still frames."""
        return self.simulation is not None

    @property
    def playing(self) -> bool:
        """Whether the wall clock drives the simulation (between :meth:`play` and
        :meth:`pause`).
        """
        return self._clock is not None

    @property
    def time(self) -> float | None:
        """The simulated time in seconds (None without a simulation)."""
        return None if self.simulation is None else self.simulation.time

    def state(self, guard: bool = True) -> FaceState:
        """The simulation's current :class:`~wrinkle_vis.core.face.FaceState`, through the
        face's fold guard unless ``guard`` is False (a refined frame is guarded on its
        refined skin, after the refinement).
        """
        if self.simulation is None:
            raise RuntimeError("no simulation: show the still frame (face.evaluate)")
        return self.simulation.state(guard)

    # ------------------------------------------------------------------ control
    def play(self, face: FaceModel, t: float, now: float) -> None:
        """Start (or go on) at wall-clock ``now``: the simulation as it is, else a new one
        of ``face`` at simulated time ``t`` (re-simulated as :meth:`scrub` does).
        """
        if self.simulation is None or self._face is not face:
            self._start(face, t)
        self._clock, self._lag = float(now), 0.0

    def sync(self, now: float) -> None:
        """Set the wall clock to ``now`` if playing, the lag so far forgotten: what
        :meth:`play` itself took to start a simulation (building and factorizing the skin,
        re-simulating to the time chosen) is not wall-clock time the skin should have moved
        through, so the first frame is the state Play started from and the simulation
        follows the clock from there.
        """
        if self._clock is not None:
            self._clock, self._lag = float(now), 0.0

    def pause(self) -> None:
        """Stop following the wall clock; the state stays."""
        self._clock, self._lag = None, 0.0

    def stop(self) -> None:
        """End the simulation: still frames again."""
        self.pause()
        self.simulation, self._face = None, None

    def reset(self, face: FaceModel) -> None:
        """Back to rest at :math:`t = 0` (a simulation of ``face``; playing on if playing)."""
        if self.simulation is None or self._face is not face:
            self._start(face, 0.0)
        self.simulation.reset()
        self._lag = 0.0

    def scrub(self, face: FaceModel, t: float) -> None:
        """The simulation at time ``t`` (module docstring); playing on if playing."""
        self._start(face, t)
        self._lag = 0.0

    def follow(self, face: FaceModel) -> None:
        """The face or the command changed: while playing, go on with the new command from
        the current state (a new face: re-simulated to the current time); while paused,
        end the simulation (the still frame shows).
        """
        if self.simulation is None:
            return
        if not self.playing or face.skin_model != "physical":
            self.stop()
        elif face is not self._face:
            self._start(face, self.simulation.time)
        else:
            self.simulation.timeline = self._timeline  # the new command, the state kept

    def tick(self, now: float) -> bool:
        r"""Advance the simulation to wall-clock ``now``: by the elapsed time
        :math:`\Delta` plus what the last tick left, in whole steps of :math:`h`, at most
        :attr:`max_steps` of them (the rest of a longer lag is dropped); past the end of
        the timeline, from rest at :math:`t = 0` again. Returns whether it moved.
        """
        if self.simulation is None or self._clock is None:
            return False
        h = self._h()
        self._lag += max(0.0, float(now) - self._clock)
        self._clock = float(now)
        n = math.floor(self._lag / h + 1e-9)
        if n > self.max_steps:
            self.dropped_s += (n - self.max_steps) * h
            self._lag -= (n - self.max_steps) * h
            n = self.max_steps
        self._lag = max(0.0, self._lag - n * h)
        duration = self._duration_s()
        for _ in range(n):
            if duration > 0.0 and self.simulation.time + 0.5 * h > duration:
                self.simulation.reset()  # round and round, as on the geometric skin
            self.simulation.advance(h)
        self.played_s += n * h
        return n > 0

    # ------------------------------------------------------------------ helpers
    def _h(self) -> float:
        face = self._face
        return (self.simulation.material if self.simulation is not None
                else face.material).time_step

    def _start(self, face: FaceModel, t: float) -> None:
        r"""A simulation of ``face`` at the last step :math:`t_n = n h \le t`: the steps of
        the last :attr:`history_s` seconds simulated, from rest at :math:`t = 0` when
        that is all of them, else from the still equilibrium at :math:`t_n - k h` (its
        activations at their commands).
        """
        sim = Simulation(face, self._timeline)
        self.simulation, self._face = sim, face
        h = sim.material.time_step
        n = math.floor(max(0.0, float(t)) / h + 1e-9)
        k = min(n, math.ceil(self.history_s / h - 1e-9))
        self.resimulated = k == n
        if not self.resimulated:
            t0 = (n - k) * h
            sim.activations = sim.command(t0)
            acts = dict(zip(face.muscle_names, map(float, sim.activations), strict=True))
            sim.x = face.physical_skin(sim.material).equilibrium(
                face.muscle_displacement(acts))
            sim.v[:] = 0.0
            sim.time = t0
        for _ in range(k):
            sim.advance(h)
