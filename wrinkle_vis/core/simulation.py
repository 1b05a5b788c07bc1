r"""Time stepping the physically based skin of a face (:mod:`wrinkle_vis.core.skin`).

A :class:`Simulation` holds one state of a face's spring skin (positions, velocities, the
muscles' current activations and the time) and advances it frame by frame for an activation
*timeline*:

* ``None``: neutral;
* an expression name, an :class:`~wrinkle_vis.core.expressions.Expression` or a mapping of
  muscle name to activation: a step to those activations at :math:`t = 0`;
* a callable ``t -> activations`` (any of the above) for ramps, tracks and the like.

The command at the end of each step is held over it and filtered by the muscles'
activation dynamics (:func:`~wrinkle_vis.core.skin.activation_response`). Each step returns
a :class:`~wrinkle_vis.core.face.FaceState` whose fields are computed by the same code as
the geometric skin's, on the simulated skin; it carries ``time`` (seconds) and
``velocities`` ``(n, 3)`` (face units per second).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from .skin import SkinMaterial, activation_response

__all__ = ["Simulation"]


class Simulation:
    """One running simulation of ``face``'s physically based skin.

    Parameters
    ----------
    face : FaceModel
    timeline : see the module docstring
    material : SkinMaterial, optional
        Default the face's ``material``.

    Attributes
    ----------
    time : float
        Simulated seconds since the start.
    x, v : (n, 3) float
        Positions and velocities of the skin's vertices.
    activations : (M,) float
        The muscles' current (filtered) activations, in the face's muscle order.
    """

    def __init__(self, face, timeline=None, material: SkinMaterial | None = None):
        self.face = face
        self.material = material or face.material
        self.skin = face.physical_skin(self.material)
        self.timeline = timeline
        self.reset()

    @property
    def timeline(self):
        """What the muscles are commanded to do (module docstring); setting it keeps the
        state (the skin goes on from where it is).
        """
        return self._timeline

    @timeline.setter
    def timeline(self, timeline) -> None:
        if timeline is None or not callable(timeline) or isinstance(timeline, str):
            fixed = self.face.activations_for({} if timeline is None else timeline)
            self._command: Callable[[float], dict] = lambda t: fixed
        else:
            self._command = lambda t: self.face.activations_for(timeline(t))
        self._timeline = timeline

    def reset(self) -> None:
        """Back to the rest skin, at rest, at time 0, all muscles relaxed."""
        self.time = 0.0
        self.x = self.skin.rest.copy()
        self.v = np.zeros_like(self.x)
        self.activations = np.zeros(len(self.face.muscles))
        self._pull: tuple[np.ndarray, np.ndarray] | None = None  # (activations, their pull)

    def muscle_pull(self) -> np.ndarray:
        """``(n, 3)``: the muscles' summed displacement at the current :attr:`activations`
        (:meth:`~wrinkle_vis.core.face.FaceModel.muscle_displacement`), computed once per
        set of activations (a step and the state after it share it).
        """
        cached = self._pull
        if cached is None or not np.array_equal(cached[0], self.activations):
            pull = self.face.muscle_displacement(self._named(self.activations))
            cached = self._pull = (self.activations.copy(), pull)
        return cached[1]

    def command(self, t: float) -> np.ndarray:
        """``(M,)``: the timeline's activations at time ``t``, in muscle order."""
        acts = self._command(float(t))
        return np.array([acts[n] for n in self.face.muscle_names], dtype=float)

    def step(self, dt: float | None = None):
        """Advance by ``dt`` seconds (default the material's ``time_step``) and return the
        new :class:`~wrinkle_vis.core.face.FaceState` (with ``time`` and ``velocities``).
        """
        self.advance(dt)
        return self.state()

    def advance_to(self, t: float) -> None:
        """Advance in steps of the material's ``time_step`` (the last one shortened) to
        time ``t``, computing no fields on the way; nothing when ``t`` is not ahead.
        """
        h = self.material.time_step
        while self.time < t - 1e-9 * h:
            self.advance(min(h, t - self.time))

    def advance(self, dt: float | None = None) -> None:
        """Advance by ``dt`` seconds (default the material's ``time_step``) without
        computing the fields (:meth:`step` does both; the app takes several steps a frame
        and draws the last).
        """
        h = self.material.time_step if dt is None else float(dt)
        if not (h > 0.0 and np.isfinite(h)):
            raise ValueError(f"time step dt = {dt!r} must be a positive number of seconds")
        t1 = self.time + h
        self.activations = activation_response(self.activations, self.command(t1), h,
                                               self.material.activation_time)
        self.x, self.v = self.skin.step(self.x, self.v, self.muscle_pull(), h)
        self.time = t1

    def state(self, guard: bool = True):
        """The :class:`~wrinkle_vis.core.face.FaceState` of the current state, through the
        face's fold guard (:attr:`~wrinkle_vis.core.face.FaceModel.fold_guard`) unless
        ``guard`` is False (for a caller that refines the state first and guards that); the
        simulated positions :attr:`x` are left as they are.
        """
        state = self.face.physical_state(self._named(self.activations), self.x,
                                         time=self.time, velocities=self.v,
                                         muscle_pull=self.muscle_pull())
        return self.face.guarded(state, None) if guard else state

    def energy(self) -> float:
        """Kinetic plus potential energy of the current state (for the current
        activations' targets).
        """
        return self.skin.energy(self.x, self.v, self.muscle_pull())

    def run(self, duration: float, dt: float | None = None, *, guard: bool = True
            ) -> Iterator:
        """Yield the state after each step of ``dt`` until ``duration`` seconds have passed
        since the current time (the last step shortened to land on it); ``guard`` as in
        :meth:`state`.
        """
        h = self.material.time_step if dt is None else float(dt)
        if not (h > 0.0 and np.isfinite(h)):
            raise ValueError(f"time step dt = {dt!r} must be a positive number of seconds")
        if not (float(duration) >= 0.0 and np.isfinite(duration)):
            raise ValueError(f"duration = {duration!r} must be a non-negative number of "
                             "seconds")
        end = self.time + float(duration)
        while self.time < end - 1e-9 * h:
            self.advance(min(h, end - self.time))
            yield self.state(guard)

    def _named(self, a: np.ndarray) -> dict[str, float]:
        return {n: float(x) for n, x in zip(self.face.muscle_names, a, strict=True)}
