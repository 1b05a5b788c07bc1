r"""The fold guard: keep the skin from passing through itself (the paper's future work).

Two guards, each a function of the rest skin, the skin deformed by the muscles' pulls, the
wrinkle amplitude :math:`W` and the triangles, so any skin model can use them:

* **Wrinkles** (:func:`guard_wrinkles`). Each vertex moves by :math:`W` along its normal.
  With :math:`r_\pm(x)` the radius of the largest ball empty of the skin that touches it at
  :math:`x` on the side :math:`\pm n` (the medial ball: empty of the vertices,
  :func:`medial_radii`, and of every triangle not incident to :math:`x`,
  :func:`triangle_radii`), the point
  :math:`x + t\,n(x)` with :math:`0 \le t < r_+(x)` (or :math:`-r_-(x) < t \le 0`) has
  :math:`x` as its unique closest skin point. Two skin points moved by less than their own
  medial radius therefore never land on the same place, whatever the neighbour does: the
  displaced skin is injective (``docs/model.md`` has the proof). The guard bounds
  :math:`|W|` by :math:`B = \eta\, r_{\operatorname{sign} W}` with the soft clamp
  :func:`soft_clamp`, the identity up to a knee :math:`\kappa B`, so :math:`W` stays the
  paper's, bit for bit, wherever it is far from any collision.
* **Pulls** (:func:`skin_scale`). A pull that drags skin over its neighbour turns triangles
  over before any wrinkle. Each triangle's signed area along its rest normal,
  :math:`\sigma_t(s) = N_t \cdot (e_1 + s\,\delta_1) \times (e_2 + s\,\delta_2) / |N_t|^2`
  for the pull scaled by :math:`s` (a quadratic with :math:`\sigma_t(0) = 1`), must stay
  above :math:`\sigma_{\min}`; the first :math:`s^*_t` where it would not bounds the pull of
  the triangle's corners, again through :func:`soft_clamp` (the pull is untouched where every
  triangle around the vertex keeps :math:`\sigma_{\min}` up to :math:`1/\kappa` times it).

The package's modules, each importing only those before it: ``_base``, ``pulls``,
``balls``, ``fans``, ``certified``, ``frame``.
"""
from __future__ import annotations

from ._base import (  # noqa: F401
    FoldGuard,
    _any_corner,
    _closest_on_triangles,
    _cross,
    _in_box,
    _incidence,
    _near_edges,
    _near_triangles,
    _rows_dot,
    _skin_edges,
    _sq,
    _terms_edges,
    _vertex_normals,
    soft_clamp,
)
from .balls import (  # noqa: F401
    _GAP_CORNERS,
    _GAP_CUTS,
    _GAP_NEAR,
    _SUSPECTS_K,
    _apart,
    _cleared,
    _deformed_lows,
    _deformed_radii,
    _enclosing_sq,
    _expand,
    _fill_gaps,
    _fill_near,
    _first_found,
    _gap_bounds,
    _gap_cleared,
    _gap_moves,
    _gaps_apart,
    _gaps_clear,
    _gaps_empty,
    _gaps_skip,
    _heights,
    _least_height,
    _lift,
    _lifted_near,
    _local_skin,
    _lone_neighbours,
    _longest_edge,
    _nearest_skin_vertices,
    _needed,
    _rest_gaps,
    _rest_radii,
    _shrink_on_triangles,
    _skin_lift,
    _suspects,
    _to_search,
    _triangle_seps,
    _triangles_search,
    _vertex_hits,
    fold_radii,
    medial_radii,
    triangle_radii,
)
from .certified import (  # noqa: F401
    _CERT_ASSEMBLIES,
    _CERT_MAX_POINTS,
    _CERT_REACH,
    _TABLE_CUTS,
    _TABLE_STEPS,
    _TWO_SQRT2,
    Certified,
    _assembly_bounds,
    _balls_per_vertex,
    _build_assembly_bounds,
    _build_muscle_bounds,
    _certificates,
    _clamp_limit,
    _clamp_only,
    _empty_balls,
    _may_wrinkle,
    _measured,
    _muscle_bounds,
    _near_of,
    _near_table,
    _refined_limits,
    _skin_bounds,
    _table_bounds,
    _verified_radii,
    certify,
)
from .fans import (  # noqa: F401
    _FAN_MARGIN,
    _FAN_PAIRS,
    _FAN_REGIONS,
    _FAN_ROUNDS,
    _PLANE_MARGIN,
    _RADIX,
    _across,
    _apart_by_planes,
    _certified_fans,
    _cleared_by_rest,
    _csr_rows,
    _edge_runs,
    _fan_certificates,
    _fan_edges,
    _fan_incidence,
    _fan_pairs,
    _fan_region,
    _fan_structure,
    _fan_terms,
    _FanIncidence,
    _link_margins,
    _loose_pairs,
    _margin,
    _open,
    _pairs_cross,
    _pairs_of,
    _projected_length,
    _rest_fan_margins,
    _rest_filter,
    _rest_region,
    _rest_sure,
    _ring,
    _row_products,
    _scale_back,
    _scaled_fans,
    _segment_max,
    _stable_order,
    _stars_along,
    _sub_rows,
    _triangles_within,
    _two_rings,
    _wedges_clear,
    guard_fans,
)
from .frame import (  # noqa: F401
    GuardResult,
    _clamped,
    _held_wrinkles,
    _rewrinkled,
    guard_amount,
    guard_frame,
    guard_wrinkles,
    guarded,
)
from .pulls import (  # noqa: F401
    _COLD_MARGIN,
    _GRAPH_CACHE_EDGES,
    _LOCAL_BUDGET,
    _SUBSET_BYTES,
    _SUBSETS,
    _cold_limits,
    _cold_pass,
    _cross_rows,
    _edge_graph,
    _edge_structure,
    _first_root,
    _limits,
    _local_limits,
    _lowest_sigma,
    _pulled_triangles,
    _quadratic,
    _reweigh,
    _row_terms,
    _start_terms,
    _terms_rows,
    _triangles_of,
    _update,
    _weights,
    pull_terms,
    skin_scale,
)

__all__ = ["Certified", "FoldGuard", "GuardResult", "certify", "fold_radii", "guard_amount",
           "guard_fans", "guard_frame", "guard_wrinkles", "guarded", "medial_radii", "pull_terms",
           "skin_scale", "soft_clamp", "triangle_radii"]
