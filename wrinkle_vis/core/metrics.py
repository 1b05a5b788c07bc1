r"""The numbers a parameter study records for one frame, defined once (numpy and scipy only).

:func:`frame_metrics` measures an evaluated :class:`~wrinkle_vis.core.face.FaceState`; the
sweep (:mod:`wrinkle_vis.sweep`) writes its result as one row of its table, and
:data:`METRICS` says what each number is (the documentation's table reads it). Everything
is measured with :mod:`wrinkle_vis.core.analysis`, so the numbers are the ones the realism
tests check.

The measures, for a frame with final points :math:`x_i`, total amplitude :math:`W_i` and
the active muscles :math:`m` (activation above 0):

- **Amplitude**: :math:`\min_i W_i`, :math:`\max_i W_i` and the range
  :math:`\max W - \min W`.
- **Crests along the fibres**: each active muscle is cut on its rest skin by the plane that
  holds its central fibre (:func:`fibre_section`); along the longest piece of that cut inside
  its wrinkling region the muscle's own :math:`W_m` has :math:`c_m` crests
  (:func:`~wrinkle_vis.core.analysis.crests`) of prominence at least
  :math:`\rho\,(\max W_m - \min W_m)` along the cut (:math:`\rho` = ``prominence``, 0.1). The
  model puts :math:`n_w` crests there (Eq. 6, 7), so ``crests_match`` is the fraction of the
  wrinkling muscles with :math:`c_m = n_{w,m}`.
- **Furrows**: on the same cuts, the furrow bottoms
  (:func:`~wrinkle_vis.core.analysis.furrows`): their number, the median depth (the lower
  bounding crest above the bottom) and the median side slope
  :math:`\arctan \max |dW/ds|` in degrees, pooled over the muscles.
- **Compression** :math:`\varepsilon` (Eq. 10, 11) on the active muscles' areas of influence,
  pooled: the mean, the 95th percentile, the largest, and the fraction of those vertices
  compressed (:math:`\varepsilon > 0`).
- **Fold contact**: the pairs of skin triangles that cross each other
  (:func:`~wrinkle_vis.core.mesh.self_intersections`) in the frame and at rest; the pairs that
  cross in the frame but not at rest are the folds' own (``crossings_added``), and
  ``folds_intersect`` says whether there are any. Triangles turned over against their rest
  normal (:func:`~wrinkle_vis.core.analysis.turned_over`) are counted too.
- **Time**: the expression's time :math:`t` of the frame in seconds (NaN for a frame at the
  expression's peak, not on its ramp) and the seconds the evaluation took (the one number
  that differs between two runs of the same parameters).
"""

from __future__ import annotations

import math

import numpy as np

from .analysis import Polyline, crests, furrows, section, turned_over
from .mesh import TriangleSurface, self_intersections

__all__ = ["METRICS", "fibre_section", "frame_metrics", "muscle_metrics", "rest_crossings"]

#: Every metric of :func:`frame_metrics`: name -> (unit, meaning). Per-muscle crest counts
#: come as well, named ``crests:<muscle>`` (see :func:`muscle_metrics`).
METRICS: dict[str, tuple[str, str]] = {
    "W_min": ("length", "the smallest total wrinkle amplitude W"),
    "W_max": ("length", "the largest W"),
    "W_range": ("length", "max W - min W"),
    "active_muscles": ("count", "muscles with activation above 0"),
    "wrinkling_muscles": ("count", "active muscles whose central fibre cut holds a wrinkle"),
    "crests": ("count", "crests along the active muscles' central fibres, summed"),
    "n_w": ("count", "n_w of those muscles, summed (what the model puts there)"),
    "crests_match": ("1", "fraction of the wrinkling muscles with crests = n_w"),
    "furrows": ("count", "furrow bottoms along the central fibres, summed"),
    "furrow_depth_median": ("length", "median furrow depth on the fibres"),
    "furrow_side_slope_deg_median": ("deg", "median steepest furrow wall, arctan |dW/ds|"),
    "eps_mean": ("1", "mean compression eps on the active muscles' areas of influence"),
    "eps_p95": ("1", "95th percentile of eps there"),
    "eps_max": ("1", "largest eps there"),
    "compressed_fraction": ("1", "fraction of those vertices with eps > 0"),
    "crossings_rest": ("count", "pairs of skin triangles crossing each other at rest"),
    "crossings": ("count", "pairs crossing in the frame"),
    "crossings_added": ("count", "pairs crossing in the frame that do not at rest"),
    "folds_intersect": ("bool", "whether crossings_added > 0"),
    "turned_over": ("count", "triangles whose normal turned more than 90 deg from rest"),
    "time_s": ("s", "the expression's time of the frame (NaN: its peak)"),
    "frame_seconds": ("s", "wall-clock seconds the evaluation took (not deterministic)"),
}


def fibre_section(state, muscle: str, region=None) -> Polyline | None:
    r"""The cut of the rest skin along a muscle's central fibre, inside its wrinkling region.

    The plane holds the mean contraction direction :math:`\bar d` and the mean rest normal
    :math:`\bar n` of the region's central vertices (:math:`\gamma \le 0.25`; all region
    vertices when none) and passes through their centroid: its normal is
    :math:`\bar d \times \bar n`. For a linear muscle that is the plane through
    :math:`m_A m_I` along the skin, for a sheet muscle the one through the centre of its
    fibres; a plug-in type is cut the same way from its own fields.

    Parameters
    ----------
    state : FaceState
        The frame (its ``face.skin`` is cut and its ``fields[muscle]["W"]`` sampled).
    muscle : str
        The muscle's name.
    region : MuscleRegion, optional
        ``face.muscle(muscle).region(state.rest_points)``, if already computed.

    Returns
    -------
    Polyline or None
        The longest piece of the cut, its ``values`` the muscle's W (0 outside its region);
        None when the region is empty or its directions cancel (a ring).
    """
    skin = state.face.skin
    rest = state.rest_points
    reg = region if region is not None else state.face.muscle(muscle).region(rest)
    inside = np.asarray(reg["in_region"], bool)
    if inside.sum() < 3:
        return None
    centre = inside & (np.nan_to_num(np.asarray(reg["gamma"], float), nan=np.inf) <= 0.25)
    pick = centre if centre.sum() >= 3 else inside
    d = np.nan_to_num(np.asarray(reg["direction"], float)[pick]).mean(axis=0)
    n = skin.vertex_normals()[pick].mean(axis=0)
    normal = np.cross(d, n)
    scale = float(np.linalg.norm(d) * np.linalg.norm(n))
    if not np.linalg.norm(normal) > 1e-9 * max(scale, 1e-300):
        return None
    values = np.nan_to_num(np.asarray(state.fields[muscle]["W"], float), nan=0.0)
    lines = section(skin, values, rest[pick].mean(axis=0), normal, inside, order_axis=d)
    return max(lines, key=lambda line: line.length, default=None)


def muscle_metrics(state, muscle: str, prominence: float = 0.1) -> dict:
    r"""Crests and furrows of one muscle's W along its central fibre (:func:`fibre_section`).

    Parameters
    ----------
    state : FaceState
        The frame.
    muscle : str
        The muscle's name.
    prominence : float, default 0.1
        The least crest or furrow counted, as a fraction of the range of the muscle's W
        along the cut.

    Returns
    -------
    dict
        ``crests`` (int), ``n_w`` (the muscle's :math:`n_w`), ``depths`` and
        ``side_slopes_deg`` (lists of float, one per furrow); ``crests`` is 0 and the lists
        empty where the cut holds no wrinkle.
    """
    m = state.face.muscle(muscle)
    line = fibre_section(state, muscle)
    out = {"crests": 0, "n_w": int(getattr(m, "n_wrinkles", 0)), "depths": [],
           "side_slopes_deg": []}
    if line is None or line.values is None or len(line) < 3:
        return out
    span = float(np.ptp(line.values))
    if not span > 0.0:
        return out
    c = crests(line.s, line.values, prominence * span)
    f = furrows(line.s, line.values, prominence * span)
    out.update(crests=len(c), depths=[float(x) for x in f.depth],
               side_slopes_deg=[float(x) for x in f.side_slope_deg])
    return out


def rest_crossings(skin: TriangleSurface) -> np.ndarray:
    """``(k, 2)``: the crossing triangle pairs of a rest skin (to pass to
    :func:`frame_metrics` when many frames share the skin).
    """
    return self_intersections(skin)


def frame_metrics(state, *, prominence: float = 0.1, rest_pairs=None,
                  time_s: float | None = None, frame_seconds: float = math.nan) -> dict:
    """Every metric of :data:`METRICS` for one frame, and ``crests:<muscle>`` per active
    muscle (see the module's notes for the definitions).

    Parameters
    ----------
    state : FaceState
        The evaluated frame.
    prominence : float, default 0.1
        The least crest or furrow, as a fraction of each cut's range (:func:`muscle_metrics`).
    rest_pairs : (k, 2) int array_like, optional
        The crossing pairs of ``state.face.skin`` at rest (:func:`rest_crossings`); computed
        when not given.
    time_s : float, optional
        The expression's time of the frame; None for its peak (NaN in the result).
    frame_seconds : float
        How long the evaluation took (recorded as given).

    Returns
    -------
    dict of str to float, int or bool
    """
    W = np.asarray(state.W, float)
    out: dict = {"W_min": float(W.min()), "W_max": float(W.max()),
                 "W_range": float(W.max() - W.min())}
    active = [m for m, a in state.activations.items() if a > 0.0]
    out.update(_fibres(state, active, prominence))
    out.update(_compression(state, active))
    out.update(_crossings(state, rest_pairs))
    out["time_s"] = math.nan if time_s is None else float(time_s)
    out["frame_seconds"] = float(frame_seconds)
    return out


def _median(values: list) -> float:
    return float(np.median(values)) if values else math.nan


def _fibres(state, active: list[str], prominence: float) -> dict:
    per = {m: muscle_metrics(state, m, prominence) for m in active}
    wrinkling = [m for m in active if per[m]["crests"] > 0]
    depths = [d for m in active for d in per[m]["depths"]]
    slopes = [s for m in active for s in per[m]["side_slopes_deg"]]
    out = {"active_muscles": len(active), "wrinkling_muscles": len(wrinkling),
           "crests": int(sum(per[m]["crests"] for m in active)),
           "n_w": int(sum(per[m]["n_w"] for m in active)),
           "crests_match": (sum(per[m]["crests"] == per[m]["n_w"] for m in wrinkling)
                            / len(wrinkling)) if wrinkling else math.nan,
           "furrows": len(depths), "furrow_depth_median": _median(depths),
           "furrow_side_slope_deg_median": _median(slopes)}
    out.update({f"crests:{m}": per[m]["crests"] for m in active})
    return out


def _compression(state, active: list[str]) -> dict:
    eps = [np.asarray(state.fields[m]["eps"], float) for m in active]
    v = np.concatenate([e[np.isfinite(e)] for e in eps]) if eps else np.zeros(0)
    if len(v) == 0:
        return {"eps_mean": math.nan, "eps_p95": math.nan, "eps_max": math.nan,
                "compressed_fraction": math.nan}
    return {"eps_mean": float(v.mean()), "eps_p95": float(np.percentile(v, 95)),
            "eps_max": float(v.max()), "compressed_fraction": float((v > 0).mean())}


def _crossings(state, rest_pairs) -> dict:
    skin = state.face.skin
    rest = rest_crossings(skin) if rest_pairs is None else np.asarray(rest_pairs)
    now = self_intersections(skin.with_points(state.points))
    before = {tuple(p) for p in np.sort(rest, axis=1).tolist()}
    added = sum(tuple(p) not in before for p in np.sort(now, axis=1).tolist())
    flipped = turned_over(skin, state.rest_points, state.points)
    return {"crossings_rest": len(rest), "crossings": len(now), "crossings_added": added,
            "folds_intersect": bool(added > 0), "turned_over": int(flipped.sum())}
