"""Named landmarks: their names, the built-in face's, and the similarity that maps one face's
onto another's (checked, so that swapped or misplaced landmarks are refused in one line).
"""

from __future__ import annotations

import numpy as np

from . import anatomy
from .sdf import front_hit

__all__ = ["LANDMARKS", "MAX_LANDMARK_MISFIT", "builtin_landmarks", "fit_landmarks",
           "shared_landmarks", "similarity_transform"]

#: The landmarks ``transfer_layout`` understands (L is the subject's left, +x).
LANDMARKS = ("nasion", "nose_tip", "chin", "eye_inner_L", "eye_inner_R", "eye_outer_L",
             "eye_outer_R", "mouth_corner_L", "mouth_corner_R")


def builtin_landmarks() -> dict[str, tuple]:
    """Named landmarks on the built-in skin (see :data:`LANDMARKS`), mm."""
    at = {"nasion": (0.0, 8.0), "nose_tip": (0.0, -29.0), "chin": (0.0, -95.0),
          "eye_inner_L": (19.0, 0.0), "eye_inner_R": (-19.0, 0.0),
          "eye_outer_L": (45.0, -1.0), "eye_outer_R": (-45.0, -1.0),
          "mouth_corner_L": (23.0, -59.0), "mouth_corner_R": (-23.0, -59.0)}
    return {k: tuple(map(float, front_hit(anatomy.skin_sdf, *xy))) for k, xy in at.items()}


def similarity_transform(source, target) -> tuple[np.ndarray, float, np.ndarray]:
    r"""Least-squares similarity :math:`y = s R x + t` from ``(k, 3)`` source to target
    landmarks (Umeyama 1991), ``k >= 3``.

    Returns
    -------
    rotation : (3, 3) float
    scale : float
    translation : (3,) float
    """
    x, y = np.asarray(source, float), np.asarray(target, float)
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    u, sig, vt = np.linalg.svd(yc.T @ xc / len(x))
    d = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        d[-1] = -1
    rot = u @ np.diag(d) @ vt
    scale = float((sig * d).sum() / (xc**2).sum(axis=1).mean())
    return rot, scale, my - scale * rot @ mx


#: How far a landmark may lie from where the best similarity puts it, as a fraction of the
#: landmarks' spread (their RMS distance from their mean): real scans against the built-in
#: face stay under 0.3; two swapped landmarks are off by more than 1.
MAX_LANDMARK_MISFIT = 0.75


def fit_landmarks(source: dict, target: dict) -> tuple[np.ndarray, float, np.ndarray]:
    r"""The similarity :math:`y = s R x + t` from ``source`` to ``target`` landmarks (their
    shared names, :func:`similarity_transform`), after checking that it means something.

    Refused, each in one line naming the landmarks: fewer than 4 shared names; target
    landmarks at one point or on one line (no rotation follows from them); landmarks that
    a mirror image fits and no rotation does (left and right swapped); landmarks that lie
    more than :data:`MAX_LANDMARK_MISFIT` of the landmarks' spread from where the fit puts
    them (swapped or misplaced: the worst named first).

    Raises
    ------
    ValueError
        As above, with the way out.
    """
    names = shared_landmarks(source, target)
    x = np.array([source[n] for n in names], float)
    y = np.array([target[n] for n in names], float)
    spread = float(np.sqrt(((y - y.mean(axis=0)) ** 2).sum(axis=1).mean()))
    sv = np.linalg.svd(y - y.mean(axis=0), compute_uv=False)
    if not spread > 1e-9 * max(1.0, float(np.abs(y).max())):
        raise ValueError(f"the landmarks {', '.join(names)} are all at one point; place each "
                         "on its own feature of the face")
    if sv[1] < 0.05 * sv[0]:
        raise ValueError(f"the landmarks {', '.join(names)} lie on one line; place them on "
                         "the face's features (the eyes' corners are left and right of the "
                         "nose, the chin below it)")
    rot, scale, shift = similarity_transform(x, y)
    off = np.linalg.norm(scale * x @ rot.T + shift - y, axis=1) / spread
    if off.max() <= MAX_LANDMARK_MISFIT:
        return rot, scale, shift
    if _mirror_misfit(x, y, spread).max() <= MAX_LANDMARK_MISFIT:
        raise ValueError("the landmarks are a mirror image of the face's: _L and _R are "
                         "swapped (_L is the subject's left, on your right as you face "
                         "them); swap them")
    worst = [f"{names[i]} ({off[i]:.2f})" for i in np.argsort(-off)
             if off[i] > MAX_LANDMARK_MISFIT]
    raise ValueError(f"the landmarks {', '.join(worst)} lie far from where the others put "
                     f"them (by that fraction of the landmarks' spread; at most "
                     f"{MAX_LANDMARK_MISFIT:g} fits a face): are they swapped or misplaced? "
                     "Check them on the scan")


def _mirror_misfit(x: np.ndarray, y: np.ndarray, spread: float) -> np.ndarray:
    """``(k,)``: each landmark's distance from the best fit that may mirror, over ``spread``."""
    mx, my = x.mean(axis=0), y.mean(axis=0)
    u, sig, vt = np.linalg.svd((y - my).T @ (x - mx) / len(x))
    m = u @ vt  # orthogonal, possibly a reflection
    scale = float(sig.sum() / ((x - mx) ** 2).sum(axis=1).mean())
    return np.linalg.norm(scale * (x - mx) @ m.T + my - y, axis=1) / spread


def shared_landmarks(source: dict, target: dict) -> list[str]:
    """The names of ``source`` that ``target`` has too, in ``source``'s order.

    Raises
    ------
    ValueError
        If there are fewer than 4 (a similarity needs them), naming the shared ones and
        :data:`LANDMARKS`.
    """
    names = [n for n in source if n in target]
    if len(names) < 4:
        raise ValueError(
            f"transfer needs at least 4 landmarks named in both the layout and the target; "
            f"shared: {names or 'none'}. Known names: {', '.join(LANDMARKS)}")
    return names
