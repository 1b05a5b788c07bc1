r"""Can the skin show a muscle's wrinkles? The half period against the mesh's edge length.

A muscle's wrinkles repeat every :math:`2u` along its fibre (Eq. 6,
:math:`u = (1 - \lambda_w) R / (2 n_w)`). Sampled at the skin's vertices, a furrow and a
bulge need at least a vertex each, so when :math:`u` is below the typical (median) edge
length the wrinkles alias into noise. :func:`undersampled_muscles` finds those muscles and
:func:`warn_undersampled` warns about them with :class:`UndersampledWrinklesWarning`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from .mesh import TriangleSurface

__all__ = ["Undersampled", "UndersampledWrinklesWarning", "undersampled_line",
           "undersampled_muscles", "warn_undersampled"]


class UndersampledWrinklesWarning(UserWarning):
    """A muscle's wrinkle half period u is below the skin's median edge length."""


@dataclass(frozen=True)
class Undersampled:
    """One muscle whose wrinkles the skin cannot resolve.

    Attributes
    ----------
    muscle : str
        Its name.
    u : float
        Its half period (Eq. 6), in the face's units.
    edge_length : float
        The skin's median edge length.
    n_wrinkles : int
        Its :math:`n_w`.
    max_n_wrinkles : int
        The largest :math:`n_w` whose half period is at least ``edge_length`` (0 if none).
    n_triangles : int
        About how many skin triangles would bring the median edge down to ``u``.
    """

    muscle: str
    u: float
    edge_length: float
    n_wrinkles: int
    max_n_wrinkles: int
    n_triangles: int

    def message(self) -> str:
        """One line: the muscle, u, the edge length and the way out."""
        lower = (f"lower n_w to {self.max_n_wrinkles}" if self.max_n_wrinkles >= 1
                 else "shorten lambda_w")
        return (f"muscle {self.muscle!r}: wrinkle half period u = {self.u:.3g} (Eq. 6, "
                f"n_w = {self.n_wrinkles}) is below the skin's median edge length "
                f"{self.edge_length:.3g}, so the wrinkles alias into noise; refine the skin "
                f"(about {self.n_triangles:,} triangles, or adaptive refinement) or {lower}")


def undersampled_muscles(skin: TriangleSurface, muscles: Iterable) -> list[Undersampled]:
    """The muscles whose half period :math:`u` is below ``skin``'s median edge length.

    Parameters
    ----------
    skin : TriangleSurface
        The rest skin.
    muscles : iterable of Muscle
        Each with ``name``, ``u``, ``n_wrinkles``.

    Returns
    -------
    list of Undersampled
        In the order of ``muscles``.
    """
    lengths = skin.rest_edge_lengths
    if len(lengths) == 0:
        return []
    edge = float(np.median(lengths))
    out = []
    for m in muscles:
        u = float(m.u)
        if not (math.isfinite(u) and u < edge):
            continue
        n_w = int(m.n_wrinkles)
        max_nw = int(math.floor(n_w * u / edge)) if u > 0 else 0
        n_tri = int(math.ceil(skin.n_triangles * (edge / max(u, 1e-300)) ** 2 / 100) * 100) \
            if u > 0 else 0
        out.append(Undersampled(m.name, u, edge, n_w, max_nw, n_tri))
    return out


def warn_undersampled(skin: TriangleSurface, muscles: Iterable,
                      stacklevel: int = 2) -> list[Undersampled]:
    """Warn (:class:`UndersampledWrinklesWarning`) for each muscle of
    :func:`undersampled_muscles`; returns them.
    """
    found = undersampled_muscles(skin, muscles)
    for item in found:
        warnings.warn(item.message(), UndersampledWrinklesWarning, stacklevel=stacklevel + 1)
    return found


def undersampled_line(found: Sequence[Undersampled]) -> str | None:
    """One line for all of ``found`` (:func:`undersampled_muscles`), or None if empty.

    Muscles with the same half period and :math:`n_w` (a left and right twin) share a
    group; one group reads as :meth:`Undersampled.message` (its muscles named together),
    several as one sentence naming each group's :math:`u`, :math:`n_w` and the
    :math:`n_w` that would fit, with the largest triangle count any of them needs.
    """
    if not found:
        return None
    groups: dict[tuple, list[Undersampled]] = {}
    for item in found:
        groups.setdefault((item.u, item.n_wrinkles, item.max_n_wrinkles), []).append(item)
    if len(groups) == 1:
        first, names = found[0], [item.muscle for item in found]
        who = "muscle" if len(names) == 1 else "muscles"
        text = first.message().split(": ", 1)[1]
        return f"{who} {', '.join(map(repr, names))}: {text}"
    parts = []
    for (u, n_w, fits), items in groups.items():
        lower = f"n_w {fits} fits" if fits >= 1 else "shorten lambda_w"
        parts.append(f"{', '.join(repr(i.muscle) for i in items)} (u = {u:.3g}, n_w = {n_w}; "
                     f"{lower})")
    n_tri = max(item.n_triangles for item in found)
    return (f"muscles {', '.join(parts)}: wrinkle half periods (Eq. 6) below the skin's "
            f"median edge length {found[0].edge_length:.3g}, so their wrinkles alias into "
            f"noise; refine the skin (about {n_tri:,} triangles, or adaptive refinement) or "
            "lower their n_w")
