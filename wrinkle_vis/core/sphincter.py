r"""The sphincter muscle (orbicularis oculi, orbicularis oris): the paper's future work.

The paper (Sec. 4) leaves "the wrinkle model corresponding to the sphincter muscles that
surround the eyes and mouth" for later. This module carries its wrinkle model (Eq. 3-12)
over to an elliptic muscle that squeezes the skin towards its centre; ``docs/model.md``
("Sphincter muscles") derives it. The whole type is this file: it registers itself, and its
placement widget and glyph are named by string (``wrinkle_vis.widgets.sphincter``).
"""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass
from functools import cached_property

import numpy as np

from .mesh import closest_points
from .muscle import Geometry, Muscle, _points, parameter, plateau_fall, slack_ball
from .registry import register_muscle_type

__all__ = ["SphincterMuscle", "ellipse_arc_length"]

#: Slack on the closed AOI bounds, so points exactly on them are not lost to rounding.
_TOL = 1e-9
#: The least part of ``end_b - center`` normal to the a axis, relative to its length
#: (:math:`|v - (v\cdot e_1) e_1| > 10^{-6} |v|`): below it the b axis is rounding noise and
#: its direction meaningless.
_AXIS_TOL = 1e-6
#: Samples of the arc-length integral over a full turn (:func:`ellipse_arc_length`).
_ARC_SAMPLES = 4097


def ellipse_arc_length(t, a: float, b: float, start: float) -> np.ndarray:
    r"""``(n,)``: arc length of the ellipse with semi-axes ``a``, ``b`` from the elliptic
    angle ``start`` to ``t`` (radians, ``t`` in ``[start, start + 2π]``).

    .. math:: s(t) = \int_{t_0}^{t} \sqrt{a^2 \sin^2 \tau + b^2 \cos^2 \tau}\, d\tau

    (an incomplete elliptic integral of the second kind), by the trapezoid rule on
    :data:`_ARC_SAMPLES` samples of a full turn and linear interpolation: relative error
    below 1e-6 for :math:`b/a \ge 0.1`.
    """
    tau = np.linspace(start, start + 2.0 * np.pi, _ARC_SAMPLES)
    speed = np.sqrt((a * np.sin(tau)) ** 2 + (b * np.cos(tau)) ** 2)
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1])
                                                  * np.diff(tau))])
    return np.interp(np.asarray(t, dtype=float), tau, cumulative)


@register_muscle_type
@dataclass(frozen=True)
class SphincterMuscle(Muscle):
    r"""A sphincter muscle: an ellipse on the skin whose contraction squeezes the skin towards
    its centre, so that wrinkles radiate from it (crow's feet, lip lines).

    Parameters
    ----------
    name : str
        Unique name in a face, e.g. ``"orbicularis_oculi_L"``.
    center : (3,) array_like
        :math:`c`, the centre of the ellipse, on the skin.
    end_a : (3,) array_like
        :math:`p_a`, the end of the first semi-axis, on the skin: :math:`a = \|p_a - c\|`
        and :math:`e_1 = (p_a - c)/a`. Angles are measured from it.
    end_b : (3,) array_like
        :math:`p_b`, a point on the skin at the end of the second semi-axis: with
        :math:`e_2` the unit part of :math:`p_b - c` normal to :math:`e_1`,
        :math:`b = (p_b - c)\cdot e_2`. The ellipse lies in the plane of :math:`c, e_1, e_2`,
        with normal :math:`n = e_1 \times e_2`.
    depth : float, optional
        :math:`D`, the AOI's half thickness along :math:`n` (as the sheet's, so that the AOI
        does not reach through the head); default :math:`\max(a, b)`.
    sector_deg : float, default 180
        :math:`\Theta \in (0°, 180°]`, the half-width of the wrinkling sector around the
        central ray (180: the whole band).
    sector_center_deg : float, default 0
        :math:`\theta_c`, the central ray's elliptic angle from :math:`e_1` towards
        :math:`e_2`, in ``[-180, 180]``.
    attenuation_start_deg : float, optional
        :math:`\varphi^c \in [0, \Theta]`, where ``At`` starts to fall off the central ray
        (Eq. 12); default :math:`\Theta / 2`.
    fall_start : float, optional
        :math:`\rho_s a \in (0, a)`: up to the elliptic radius :math:`\rho_s` the skin is
        squeezed uniformly, beyond it the squeeze falls to 0 at the ellipse; default
        :math:`(1 + \lambda_w) a / 2`, the middle of the band.
    strength : float, optional
        :math:`K`, the pull at :math:`\rho_s` along :math:`e_1` at activation 1, in
        ``[0, 2 \rho_s a / \pi)``; the squeeze ratio is :math:`\kappa = K / (\rho_s a)`.
        Default :math:`0.2 \rho_s a`.
    lambda_w, n_wrinkles, k0, alpha
        As for every type: the band is :math:`\lambda_w \le \rho \le 1` and :math:`n_w`
        furrows radiate across the sector.

    Notes
    -----
    With :math:`v = x_i - c`, :math:`x_1 = v\cdot e_1`, :math:`x_2 = v\cdot e_2`,
    :math:`z = v\cdot n`:

    .. math::

        \rho_i = \sqrt{(x_1/a)^2 + (x_2/b)^2}, \quad
        \theta_i = \operatorname{atan2}(x_2/b,\ x_1/a), \quad
        \psi_i = \theta_i - \theta_c \in (-180°, 180°],

        \lambda_i = \rho_i, \quad \gamma_i = |\psi_i| / \Theta, \quad
        S_w = \{x_i \mid \lambda_w \le \lambda_i \le 1,\ 0 \le \gamma_i \le 1\}
        \ \text{(Eq. 3)}.

    The AOI is :math:`\rho_i \le 1,\ |z| \le D`. The pull (Waters' sphincter made C1)
    shrinks every ellipse :math:`\rho = \text{const}` towards the centre,

    .. math::

        \Delta x_i = -a_m \kappa\, p_{\rho_s, 1}(\rho_i)\, p_{D/2, D}(z_i)\,
                     (x_1 e_1 + x_2 e_2),

    with activation :math:`a_m` and the C1 plateau :math:`p`
    (:func:`~wrinkle_vis.core.muscle.plateau_fall`), so the skin is compressed along the
    ellipse by :math:`\kappa p(\rho)`; Eq. 10's contraction direction is the ellipse's
    tangent, :math:`\operatorname{unit}(-(a/b)x_2 e_1 + (b/a) x_1 e_2)`. The periodic
    coordinate of Eq. 7 is the arc length :math:`s_i` of the band's middle ellipse
    (:math:`\rho_m = (1 + \lambda_w)/2`) from the sector's start to the angle of
    :math:`x_i`: with :math:`S` the sector's arc, Eq. 6 and 7 take
    :math:`R = S / (1 - \lambda_w)` and :math:`l_i = \lambda_w R + s_i`, so
    :math:`u = S / (2 n_w)`, :math:`w_i = s_i \bmod 2u`, and H is constant along every ray
    from the centre. ``At`` is Eq. 12 in :math:`\varphi_i = |\psi_i|`.

    :meth:`region` gives, besides the shared fields, ``rho`` (:math:`\rho_i`), ``angle_deg``
    (:math:`\psi_i` in degrees) and ``depth`` (:math:`z_i`); ``l`` is :math:`\lambda_w R +
    s_i`. ``docs/model.md`` ("Sphincter muscles") derives all of it.
    """

    type_name = "sphincter"
    widget = "wrinkle_vis.widgets.sphincter:SphincterWidget"
    glyph = "wrinkle_vis.widgets.sphincter:sphincter_glyph"

    center: tuple = parameter(
        kw_only=False, label="c", symbol="c", unit="point", shape=(3,), surface="skin",
        doc="the centre of the ellipse")
    end_a: tuple = parameter(
        kw_only=False, label="p_a", symbol="p_a", unit="point", shape=(3,), surface="skin",
        doc="the end of the first semi-axis a; angles start from it")
    end_b: tuple = parameter(
        kw_only=False, label="p_b", symbol="p_b", unit="point", shape=(3,), surface="skin",
        doc="the end of the second semi-axis b")
    _: KW_ONLY
    depth: float | None = parameter(
        label="D", symbol="D", unit="length", lo=0.0, lo_open=True, step=1.0,
        derived="depth_value", doc="the AOI's half thickness normal to the ellipse")
    sector_deg: float = parameter(
        180.0, label="Theta (deg)", symbol="Θ", unit="deg", lo=0.0, hi=180.0, lo_open=True,
        step=5.0, doc="half-width of the wrinkling sector (180: the whole band)")
    sector_center_deg: float = parameter(
        0.0, label="theta_c (deg)", symbol="θ_c", unit="deg", lo=-180.0, hi=180.0, step=5.0,
        doc="the sector's central ray, from the a axis towards the b axis")
    attenuation_start_deg: float | None = parameter(
        label="phi_c (deg)", symbol="φ_c", unit="deg", lo=0.0, step=1.0,
        derived="attenuation_start_value", doc="where the attenuation starts (Eq. 12)")
    fall_start: float | None = parameter(
        label="rho_s a", symbol="ρ_s a", unit="length", lo=0.0, lo_open=True, step=1.0,
        derived="fall_start_value", doc="where the squeeze starts to fall, along the a axis")

    def __post_init__(self):
        self._check_common()
        c, p_a, p_b = (np.asarray(getattr(self, k)) for k in ("center", "end_a", "end_b"))
        if np.linalg.norm(p_a - c) == 0.0:
            self._fail("end_a", self.end_a, "a point other than the centre",
                       "A zero semi-axis has no direction; move the end of the a axis")
        v = p_b - c
        e1 = (p_a - c) / np.linalg.norm(p_a - c)
        if not np.linalg.norm(v - (v @ e1) * e1) > _AXIS_TOL * np.linalg.norm(v):
            self._fail("end_b", self.end_b, "a point off the line through the centre and "
                       "end_a", "The ellipse needs a second axis; move the end of the b axis")
        if self.attenuation_start_deg is not None:
            self._check("attenuation_start_deg", 0.0, self.sector_deg)
        if self.fall_start is not None:
            self._check("fall_start", 0.0, self.semi_axes[0], lo_open=True, hi_open=True,
                        hint="the squeeze must start to fall inside the ellipse")
        self._check_strength()

    @classmethod
    def create(cls, name, at, skin, skull=None) -> SphincterMuscle:
        """An ellipse of semi-axes 20 and 14 (in the skin's units, mm on the built-in
        face) centred on the skin at ``at``, its a axis along x and b axis along y projected
        onto the skin's tangent plane (:meth:`Muscle.create`).
        """
        c = closest_points(skin, np.asarray(at, float).reshape(1, 3))[0]
        normal = skin.vertex_normals()[int(np.argmin(np.linalg.norm(skin.points - c,
                                                                    axis=1)))]
        ends = []
        for axis, length in ((np.array([1.0, 0.0, 0.0]), 20.0), (np.array([0.0, 1.0, 0.0]),
                                                                   14.0)):
            t = axis - (axis @ normal) * normal
            if np.linalg.norm(t) < 1e-6:  # the skin faces along x or y there
                t = np.cross(normal, axis[::-1])
            ends.append(c + length * t / np.linalg.norm(t))
        p_a, p_b = closest_points(skin, np.array(ends))
        return cls(name, tuple(c), tuple(p_a), tuple(p_b), lambda_w=0.5, n_wrinkles=3,
                   k0=0.5, sector_deg=60.0)

    # ------------------------------------------------------------ the frame
    @cached_property  # frozen: computed once per muscle
    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``((3,), (3,), (3,))``: the orthonormal axes :math:`e_1, e_2, n`."""
        c = np.asarray(self.center)
        e1 = np.subtract(self.end_a, c)
        e1 = e1 / np.linalg.norm(e1)
        v = np.subtract(self.end_b, c)
        e2 = v - (v @ e1) * e1
        norm = np.linalg.norm(e2)
        e2 = e2 / norm if norm > 0 else e2
        axes = (e1, e2, np.cross(e1, e2))
        for axis in axes:
            axis.setflags(write=False)  # cached: shared by every caller
        return axes

    @cached_property
    def semi_axes(self) -> tuple[float, float]:
        """``(a, b)``: the semi-axes along :math:`e_1` and :math:`e_2`."""
        c = np.asarray(self.center)
        e1, e2, _ = self.frame
        return (float(np.linalg.norm(np.subtract(self.end_a, c))),
                float(np.subtract(self.end_b, c) @ e2))

    @property
    def depth_value(self) -> float:
        r""":math:`D` actually used (default :math:`\max(a, b)`)."""
        return max(self.semi_axes) if self.depth is None else self.depth

    @property
    def attenuation_start_value(self) -> float:
        r""":math:`\varphi^c` actually used (default :math:`\Theta / 2`)."""
        start = self.attenuation_start_deg
        return 0.5 * self.sector_deg if start is None else start

    @property
    def fall_start_value(self) -> float:
        r""":math:`\rho_s a` actually used (default the band's middle on the a axis)."""
        if self.fall_start is None:
            return 0.5 * (1.0 + self.lambda_w) * self.semi_axes[0]
        return self.fall_start

    @property
    def squeeze(self) -> float:
        r""":math:`\kappa = K / (\rho_s a)`: how much the skin inside :math:`\rho_s` shrinks
        along the ellipse at activation 1 (below :math:`2/\pi`).
        """
        return self.strength_value / self.fall_start_value

    # ------------------------------------------------------------ the paper's lengths
    @cached_property
    def _arc(self) -> tuple[float, float, float]:
        """``(s(-Θ), s(Θ), ρ_m)``: the sector's ends on the arc from θ_c - 180°, and the
        radius of the band's middle ellipse.
        """
        a, b = self.semi_axes
        rho_m = 0.5 * (1.0 + self.lambda_w)
        start = math.radians(self.sector_center_deg) - math.pi
        half = math.radians(self.sector_deg)
        ends = rho_m * ellipse_arc_length(
            [start + math.pi - half, start + math.pi + half], a, b, start)
        return float(ends[0]), float(ends[1]), rho_m

    @property
    def sector_arc(self) -> float:
        r""":math:`S`: the sector's arc length on the band's middle ellipse."""
        s0, s1, _ = self._arc
        return s1 - s0

    @property
    def wrinkle_length(self) -> float:
        r""":math:`R = S / (1 - \lambda_w)`, so that Eq. 6 gives :math:`u = S / (2 n_w)`."""
        return self.sector_arc / (1.0 - self.lambda_w)

    @property
    def attenuation_range(self) -> tuple[float, float]:
        r"""``(phi_c, Theta)`` in degrees (Eq. 12 in :math:`|\psi|`)."""
        return (self.attenuation_start_value, self.sector_deg)

    # ------------------------------------------------------------ the model
    def _plane(self, points: np.ndarray):
        e1, e2, n = self.frame
        v = points - np.asarray(self.center)
        return v @ e1, v @ e2, v @ n

    def _geometry(self, points: np.ndarray) -> Geometry:
        a, b = self.semi_axes
        e1, e2, _ = self.frame
        x1, x2, z = self._plane(points)
        rho = np.hypot(x1 / a, x2 / b)
        theta = np.arctan2(x2 / b, x1 / a)
        psi = np.pi - np.mod(np.pi - theta + math.radians(self.sector_center_deg),
                             2 * np.pi)  # in (-pi, pi]
        phi = np.degrees(np.abs(psi))
        s0, _, rho_m = self._arc
        start = math.radians(self.sector_center_deg) - math.pi
        s = rho_m * ellipse_arc_length(psi + math.radians(self.sector_center_deg), a, b,
                                       start) - s0
        l = self.lambda_w * self.wrinkle_length + s
        in_aoi = (rho <= 1.0 + _TOL) & (np.abs(z) <= self.depth_value * (1.0 + _TOL))
        tangent = np.outer(-(a / b) * x2, e1) + np.outer((b / a) * x1, e2)
        norm = np.linalg.norm(tangent, axis=1)
        direction = tangent / np.where(norm > 0, norm, 1.0)[:, None]
        return Geometry(l=l, lam=rho, gamma=phi / self.sector_deg, coordinate=phi,
                        in_aoi=in_aoi, direction=direction,
                        extra={"rho": rho, "angle_deg": np.degrees(psi), "depth": z})

    def aoi_ball(self) -> tuple[np.ndarray, float]:
        r"""The ball around the AOI's elliptic cylinder, :math:`\rho \le 1`,
        :math:`|z| \le D`, at the centre (:meth:`Muscle.aoi_ball`).
        """
        return slack_ball(self.center, math.hypot(max(self.semi_axes), self.depth_value))

    def _falloff(self, points: np.ndarray, geometry: Geometry) -> np.ndarray:
        r"""``(n,)``: :math:`p_{\rho_s,1}(\rho)\, p_{D/2,D}(z)`, the squeeze's profile."""
        rho_s = self.fall_start_value / self.semi_axes[0]
        depth = self.depth_value
        return (plateau_fall(geometry.extra["rho"], rho_s, 1.0)
                * plateau_fall(geometry.extra["depth"], 0.5 * depth, depth))

    def unit_displacement(self, rest_points) -> np.ndarray:
        r"""``(n, 3)``: the pull at activation 1, towards the centre in the ellipse's plane,
        :math:`-\kappa\, p(\rho)\, p(z)\, (x_1 e_1 + x_2 e_2)` (zero outside the AOI).
        """
        p = _points(rest_points)
        g = self._geometry(p)
        e1, e2, _ = self.frame
        x1, x2, _ = self._plane(p)
        mag = np.where(g.in_aoi, self.squeeze * self._falloff(p, g), 0.0)
        return -mag[:, None] * (np.outer(x1, e1) + np.outer(x2, e2))
