"""Facial expressions: named sets of muscle activations, with intensity and a time ramp."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .params import control_character

__all__ = ["MAX_DURATION_S", "Expression", "paper_expressions", "smoothstep"]

#: The longest onset, hold or release, in seconds (a year): their sum and any frame count
#: at any frame rate stay finite.
MAX_DURATION_S = 3.2e7


def smoothstep(x):
    r"""``(...)``: :math:`3s^2 - 2s^3` with :math:`s` clamped to ``[0, 1]``."""
    s = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


@dataclass(frozen=True)
class Expression:
    """A named set of muscle activations, with an onset-hold-release envelope in time.

    Parameters
    ----------
    name : str
        The expression's name, e.g. ``"surprise"``.
    activations : mapping of str to float
        Muscle name to peak activation in ``[0, 1]``.
    onset_s, hold_s, release_s : float
        Durations of the rise, the plateau and the fall of :meth:`at`, in seconds.
    description : str
        What the expression does, for menus and docs.
    """

    name: str
    activations: Mapping[str, float] = field(default_factory=dict)
    onset_s: float = 1.0
    hold_s: float = 1.0
    release_s: float = 1.0
    description: str = ""

    def __post_init__(self):
        bad = control_character(str(self.name))
        if bad is not None:
            raise ValueError(f"expression {self.name!r}: the name holds the control character "
                             f"{bad}; use printable characters (any language) only")
        clean = {}
        for muscle, value in dict(self.activations).items():
            a = float(value)
            if not (0.0 <= a <= 1.0):
                raise ValueError(
                    f"expression {self.name!r}: activation of {muscle!r} = {a:g} is outside "
                    "[0, 1]"
                )
            clean[str(muscle)] = a
        object.__setattr__(self, "activations", dict(sorted(clean.items())))
        for param in ("onset_s", "hold_s", "release_s"):
            try:
                v = float(getattr(self, param))
            except OverflowError:  # an int beyond 1.8e308
                v = math.inf
            if not (math.isfinite(v) and 0.0 <= v <= MAX_DURATION_S):
                raise ValueError(f"expression {self.name!r}: {param} = {v:g} must be in "
                                 f"[0, {MAX_DURATION_S:g}] seconds")
            object.__setattr__(self, param, v)

    @property
    def duration_s(self) -> float:
        """Total length of the envelope, seconds."""
        return self.onset_s + self.hold_s + self.release_s

    def envelope(self, t: float) -> float:
        """Activation scale in ``[0, 1]`` at time ``t`` seconds (smoothstep rise and fall)."""
        t = float(t)
        if t < 0.0:
            return 0.0
        if t < self.onset_s:
            return float(smoothstep(t / self.onset_s))
        t -= self.onset_s
        if t <= self.hold_s:
            return 1.0
        t -= self.hold_s
        if t < self.release_s:
            return float(1.0 - smoothstep(t / self.release_s))
        return 0.0

    def scaled(self, intensity: float = 1.0) -> dict[str, float]:
        """Activations times ``intensity`` in ``[0, 1]``."""
        k = float(intensity)
        if not (0.0 <= k <= 1.0):
            raise ValueError(f"intensity = {k:g} is outside [0, 1]")
        return {m: a * k for m, a in self.activations.items()}

    def at(self, t: float, intensity: float = 1.0) -> dict[str, float]:
        """Activations at time ``t`` of the dynamic expression (the paper's Fig. 10)."""
        return self.scaled(intensity * self.envelope(t))

    def to_dict(self) -> dict:
        """A plain, JSON-ready dict."""
        return {"name": self.name, "activations": dict(self.activations),
                "onset_s": self.onset_s, "hold_s": self.hold_s,
                "release_s": self.release_s, "description": self.description}

    @classmethod
    def from_dict(cls, data: Mapping) -> Expression:
        """Inverse of :meth:`to_dict`."""
        return cls(**dict(data))


def _pair(prefix: str, value: float) -> dict[str, float]:
    return {f"{prefix}_L": value, f"{prefix}_R": value}


def paper_expressions() -> dict[str, Expression]:
    """The expressions of the paper's Section 3, by the built-in face's muscle names.

    - ``neutral``: no muscle.
    - ``surprise``: the pairs of frontalis major, inner and outer (sheet muscles) raise
      the eyebrows and wrinkle the forehead.
    - ``frown``: the pair of corrugator supercilii (linear) pull the brows together and
      wrinkle between them.
    - ``fear``: frontalis inner raises the inner brows while corrugator pulls them in.
    """
    return {
        "neutral": Expression("neutral", {}, description="all muscles relaxed"),
        "surprise": Expression(
            "surprise",
            {**_pair("frontalis_major", 1.0), **_pair("frontalis_inner", 1.0),
             **_pair("frontalis_outer", 1.0)},
            description="frontalis major, inner and outer raise the brows: forehead furrows",
        ),
        "frown": Expression(
            "frown", _pair("corrugator", 1.0),
            description="corrugator supercilii pull the brows together: furrows between them",
        ),
        "fear": Expression(
            "fear", {**_pair("frontalis_inner", 1.0), **_pair("corrugator", 0.8)},
            description="frontalis inner raise the inner brows, corrugator pull them in",
        ),
    }
