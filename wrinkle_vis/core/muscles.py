"""The paper's two muscle types: :class:`LinearMuscle` (Sec. 2.2) and :class:`SheetMuscle`
(Sec. 2.3).
"""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass
from functools import cached_property

import numpy as np

from .mesh import closest_points, occluded
from .muscle import (
    Geometry,
    Muscle,
    plateau_fall,
    ramp_fall,
    slack_ball,
    smooth_fall,
    waters_radial,
)
from .params import parameter
from .registry import register_muscle_type

__all__ = ["LinearMuscle", "SheetMuscle"]


#: Slack on the closed AOI bounds, so points exactly on them are not lost to rounding.
_TOL = 1e-9
#: A sheet's AOI leaves out skin with other skin in front of it along the sheet's normal,
#: farther than half the sheet's width and than this many mean edge lengths
#: (:meth:`SheetMuscle.hidden`).
HIDDEN_EDGES = 2.0


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def anchor(skin, skull, at) -> tuple[np.ndarray, np.ndarray]:
    """``((3,), (3,))``: the point of ``skin`` nearest ``at``, and an attachment on
    ``skull`` (None: the skin) 30 % of the skin's height above it, for a new muscle.
    """
    ins = closest_points(skin, np.asarray(at, float).reshape(1, 3))[0]
    lo, hi = skin.bounds()
    above = ins + np.array([0.0, 0.15 * (hi[1] - lo[1]), 0.0])
    return ins, closest_points(skull or skin, above[None])[0]


@register_muscle_type
@dataclass(frozen=True)
class LinearMuscle(Muscle):
    r"""A linear muscle (Waters 1987; paper Sec. 2.2, Fig. 2).

    Parameters
    ----------
    name : str
        Unique name in a face, e.g. ``"corrugator_L"``.
    attachment : (3,) array_like
        :math:`m_A`, the end fixed to the skull.
    insertion : (3,) array_like
        :math:`m_I`, the end in the skin; it must lie within ``radius`` of the attachment.
    radius : float
        :math:`R`, the maximal radius of influence (face units, mm for the built-in face).
    max_angle_deg : float
        :math:`\phi` in degrees, in ``(0, 90]``: the AOI needs :math:`\lambda \ge 0`, so wider
        angles would never count.
    lambda_w : float, default 0.5
        :math:`\lambda_w \in [0, 1)`; the wrinkling region is :math:`\lambda_w \le \lambda \le 1`.
    n_wrinkles : int, default 3
        :math:`n_w`, the number of wrinkles along the central fibre (Eq. 6).
    k0 : float, default 0.5
        Furrow depth factor :math:`k_0 \ge 0` (face units).
    alpha : float, default 1.0
        Shape modulation :math:`\alpha \in [-1, 10]`; :math:`\alpha > 0` gives a sharp furrow
        and a round bulge.
    attenuation_start_deg : float, optional
        :math:`\varphi^c \in [0, \phi]` (Eq. 12); default :math:`\phi / 2`.
    fall_start : float, optional
        Waters' fall-start radius :math:`R_s \in (0, R)` where the displacement peaks;
        default the insertion distance :math:`\|m_I - m_A\|`.
    strength : float, optional
        Peak displacement at activation 1, in ``[0, 2 R_s / \pi)`` so that no skin is pulled
        past the attachment; default :math:`0.2 R_s`.

    Notes
    -----
    For a skin point :math:`x_i` (Eq. 1, 2):

    .. math::

        \varphi_i = \angle(m_I - m_A, x_i - m_A) \in [0°, 180°], \quad
        l_i = \|m_A - x_i\|\cos\varphi_i, \quad
        \lambda_i = l_i / R, \quad \gamma_i = \varphi_i / \phi .

    The AOI is :math:`0 \le \lambda_i \le 1,\ \varphi_i \le \phi`; the contraction direction
    at :math:`x_i` is :math:`(m_A - x_i)/\|m_A - x_i\|`. The displacement (Waters 1987,
    made C1) is

    .. math::

        \Delta x_i = a\,K\,\cos^2\left(\frac{\varphi_i}{\phi}\frac{\pi}{2}\right)
                     r(\|x_i - m_A\|)\,\frac{m_A - x_i}{\|m_A - x_i\|}

    with activation :math:`a`, strength :math:`K` and the radial falloff :math:`r` of
    :func:`~wrinkle_vis.core.muscle.waters_radial` (fall start :math:`R_s`, end :math:`R`).
    Waters' angular factor is :math:`\cos(\ldots)`, whose slope jumps where it reaches 0 at
    :math:`\phi`; its square reaches 0 with zero slope. On a face the skin slides along its
    rest surface (:class:`~wrinkle_vis.core.face.FaceModel`).
    """

    type_name = "linear"
    widget = "wrinkle_vis.widgets.placement:LinearWidget"
    glyph = "wrinkle_vis.plotting.glyphs:linear_glyph"

    attachment: tuple = parameter(
        kw_only=False, label="m_A", symbol="m_A", unit="point", shape=(3,), surface="skull",
        doc="the end fixed to the skull")
    insertion: tuple = parameter(
        kw_only=False, label="m_I", symbol="m_I", unit="point", shape=(3,), surface="skin",
        doc="the end in the skin, within the radius of the attachment")
    _: KW_ONLY
    radius: float = parameter(
        label="R", symbol="R", unit="length", lo=0.0, lo_open=True, step=1.0,
        doc="the maximal radius of influence")
    max_angle_deg: float = parameter(
        label="Phi (deg)", symbol="Φ", unit="deg", lo=0.0, hi=90.0, lo_open=True, step=1.0,
        doc="the half-angle of the area of influence")
    attenuation_start_deg: float | None = parameter(
        label="phi_c (deg)", symbol="φ_c", unit="deg", lo=0.0, step=1.0,
        derived="attenuation_start_value", doc="where the attenuation starts (Eq. 12)")
    fall_start: float | None = parameter(
        label="R_s", symbol="R_s", unit="length", lo=0.0, lo_open=True, step=1.0,
        derived="fall_start_value", doc="Waters' fall start, where the displacement peaks")

    def __post_init__(self):
        self._check_common()
        m_a, m_i = np.asarray(self.attachment), np.asarray(self.insertion)
        length = float(np.linalg.norm(m_i - m_a))
        if length == 0.0:
            self._fail("insertion", self.insertion, "a point other than the attachment",
                       "A zero-length muscle has no direction; move the insertion")
        radius = self.radius
        if length >= radius:
            self._fail("radius", radius, f"(|m_I - m_A| = {length:g}, inf)",
                       "The insertion must lie inside the area of influence")
        phi = self.max_angle_deg
        if self.attenuation_start_deg is not None:
            self._check("attenuation_start_deg", 0.0, phi)
        if self.fall_start is not None:
            self._check("fall_start", 0.0, radius, lo_open=True, hi_open=True)
        self._check_strength()

    @classmethod
    def create(cls, name, at, skin, skull=None) -> LinearMuscle:
        """A muscle from the skull above ``at`` to ``at`` on the skin, R = 1.3 x its length,
        Φ = 25° (:meth:`Muscle.create`).
        """
        ins, att = anchor(skin, skull, at)
        length = float(np.linalg.norm(ins - att))
        return cls(name, tuple(att), tuple(ins), radius=1.3 * length, max_angle_deg=25.0,
                   lambda_w=0.4, n_wrinkles=2, k0=0.8)

    @property
    def length(self) -> float:
        r""":math:`\|m_I - m_A\|`, the length of the central fibre."""
        return float(np.linalg.norm(np.subtract(self.insertion, self.attachment)))

    @property
    def fibre(self) -> np.ndarray:
        """``(3,)``: unit central fibre direction from attachment to insertion."""
        return _unit(np.subtract(self.insertion, self.attachment))

    @property
    def fall_start_value(self) -> float:
        """:math:`R_s` actually used (the default resolved)."""
        return self.length if self.fall_start is None else self.fall_start

    @property
    def wrinkle_length(self) -> float:
        """:math:`R`, the length in Eq. 6 and 7."""
        return self.radius

    @property
    def attenuation_start_value(self) -> float:
        r""":math:`\varphi^c` actually used (default :math:`\phi / 2`)."""
        start = self.attenuation_start_deg
        return 0.5 * self.max_angle_deg if start is None else start

    @property
    def attenuation_range(self) -> tuple[float, float]:
        """``(phi_c, phi)`` in degrees (Eq. 12)."""
        return (self.attenuation_start_value, self.max_angle_deg)

    def _geometry(self, points: np.ndarray) -> Geometry:
        m_a = np.asarray(self.attachment)
        v = points - m_a
        dist = np.sqrt(np.einsum("ij,ij->i", v, v))
        l = v @ self.fibre
        safe = np.where(dist > 0, dist, 1.0)
        cos = np.where(dist > 0, np.clip(l / safe, -1.0, 1.0), 1.0)
        angle = np.degrees(np.arccos(cos))
        lam = l / self.radius
        in_aoi = (lam >= -_TOL) & (lam <= 1.0 + _TOL) & (angle <= self.max_angle_deg + _TOL)
        direction = -v / safe[:, None]
        return Geometry(l=l, lam=lam, gamma=angle / self.max_angle_deg, coordinate=angle,
                        in_aoi=in_aoi, direction=direction,
                        extra={"angle_deg": angle, "distance": dist})

    def aoi_ball(self) -> tuple[np.ndarray, float] | None:
        r"""The ball around the cylinder :math:`0 \le l \le R`, distance from the fibre
        :math:`\le R \tan\phi`, which holds the AOI's cone (:meth:`Muscle.aoi_ball`);
        None for :math:`\phi` within a degree of 90 (no bound in the fibre's normal plane).
        """
        wide = math.radians(self.max_angle_deg + 0.5)
        if wide >= math.radians(89.5):
            return None
        r = self.radius
        return slack_ball(np.asarray(self.attachment) + 0.5 * r * self.fibre,
                          r * math.hypot(0.5, math.tan(wide)))

    def _falloff(self, points: np.ndarray, geometry: Geometry) -> np.ndarray:
        angular = smooth_fall(geometry.gamma)
        radial = waters_radial(geometry.extra["distance"], self.fall_start_value, self.radius)
        return angular * radial


@register_muscle_type
@dataclass(frozen=True)
class SheetMuscle(Muscle):
    r"""A sheet muscle such as the frontalis (paper Sec. 2.3, Fig. 7, 8).

    Parameters
    ----------
    name : str
        Unique name in a face, e.g. ``"frontalis_major_L"``.
    attachment_line : (2, 3) array_like
        :math:`m_{A1}, m_{A2}` on the skull.
    insertion_line : (2, 3) array_like
        :math:`m_{I1}, m_{I2}` in the skin.
    length : float, optional
        :math:`L_s`, the AOI's length along the central fibre; default
        :math:`1.25\|m_{Ic} - m_{Ac}\|`, so the pull fades out beyond the insertion line.
    width : float, optional
        :math:`W_s`, the AOI's width; default the longer of the two lines measured across
        the fibre.
    depth : float, optional
        Half thickness of the AOI normal to the sheet (our extension, see Notes); default
        half the larger of :math:`L_s` and :math:`W_s`.
    lambda_w, n_wrinkles, k0, alpha
        As for :class:`LinearMuscle`; :math:`L_s` replaces :math:`R` in Eq. 6 and 7.
    attenuation_start : float, optional
        :math:`h^c \in [0, W_s/2]` (Eq. 15); default :math:`W_s / 4`.
    fall_start : float, optional
        Where the displacement peaks along the fibre, in ``(0, L_s)``; default
        :math:`\|m_{Ic} - m_{Ac}\|`.
    strength : float, optional
        Peak displacement at activation 1, in ``[0, 2 R_s/\pi)``; default :math:`0.2 R_s`.

    Notes
    -----
    With :math:`f = (m_{Ic} - m_{Ac})/\|m_{Ic} - m_{Ac}\|` the central fibre, :math:`s` the
    attachment line's direction made orthogonal to :math:`f`, and :math:`n = f \times s`:

    .. math::

        l_i = (x_i - m_{Ac})\cdot f, \quad h_i = |(x_i - m_{Ac})\cdot s|, \quad
        \lambda_i = l_i / L_s, \quad \gamma_i = 2 h_i / W_s \quad \text{(Eq. 13)}.

    **Extension.** The paper's AOI is a rectangle on the skin. In 3D a rectangle's prism
    would reach through the head, so the AOI is also bounded in depth,
    :math:`|(x_i - m_{Ac})\cdot n| \le` ``depth``. The contraction direction is
    :math:`-f` everywhere. The displacement is

    .. math::

        \Delta x_i = -a K\, r(l_i)\, p_{h^c, W_s/2}(h_i)\, p_{D/2, D}(d_i)\, f

    with a uniform squeeze :math:`r` along the fibre that peaks at :math:`R_s` and falls to 0
    at :math:`L_s` (:func:`~wrinkle_vis.core.muscle.ramp_fall`; Waters' 1987 model has no
    sheet, and his radial rise would leave the wrinkles near the peak flat) and the C1
    plateau :math:`p` (:func:`~wrinkle_vis.core.muscle.plateau_fall`)
    across it, from :math:`h^c` to :math:`W_s/2`, and through it, from half the depth bound
    :math:`D` to :math:`D`. The middle of the sheet moves as one and only its sides fall
    off; two sheets of one frame whose falls overlap exactly (one's :math:`[h^c, W_s/2]`
    is the other's) add up to a uniform pull, so the skin between them is not sheared.
    Every factor reaches 0 with zero slope at the AOI's boundary.
    """

    type_name = "sheet"
    widget = "wrinkle_vis.widgets.placement:SheetWidget"
    glyph = "wrinkle_vis.plotting.glyphs:sheet_glyph"

    attachment_line: tuple = parameter(
        kw_only=False, label="m_A1, m_A2", symbol="m_A", unit="point", shape=(2, 3),
        surface="skull", doc="the attachment line on the skull")
    insertion_line: tuple = parameter(
        kw_only=False, label="m_I1, m_I2", symbol="m_I", unit="point", shape=(2, 3),
        surface="skin", doc="the insertion line in the skin")
    _: KW_ONLY
    length: float | None = parameter(
        label="L_s", symbol="L_s", unit="length", lo=0.0, lo_open=True, step=1.0,
        derived="length_value", doc="the AOI's length along the central fibre")
    width: float | None = parameter(
        label="W_s", symbol="W_s", unit="length", lo=0.0, lo_open=True, step=1.0,
        derived="width_value", doc="the AOI's width")
    depth: float | None = parameter(
        label="depth", symbol="D", unit="length", lo=0.0, lo_open=True, step=1.0,
        derived="depth_value", doc="half thickness of the AOI normal to the sheet")
    attenuation_start: float | None = parameter(
        label="h_c", symbol="h^c", unit="length", lo=0.0, step=0.5,
        derived="attenuation_start_value", doc="where the attenuation starts (Eq. 15)")
    fall_start: float | None = parameter(
        label="R_s", symbol="R_s", unit="length", lo=0.0, lo_open=True, step=1.0,
        derived="fall_start_value", doc="where the displacement peaks along the fibre")

    def __post_init__(self):
        self._check_common()
        a, i = np.asarray(self.attachment_line), np.asarray(self.insertion_line)
        if np.array_equal(a[0], a[1]):
            self._fail("attachment_line", self.attachment_line, "two distinct points",
                       "A zero-length attachment line has no direction")
        if np.array_equal(i[0], i[1]):
            self._fail("insertion_line", self.insertion_line, "two distinct points",
                       "A zero-length insertion line has no direction")
        fibre = i.mean(axis=0) - a.mean(axis=0)
        if np.linalg.norm(fibre) == 0.0:
            self._fail("insertion_line", self.insertion_line,
                       "a line whose middle differs from the attachment line's middle",
                       "A zero-length muscle has no direction")
        f = _unit(fibre)
        across = (a[1] - a[0]) - ((a[1] - a[0]) @ f) * f
        if np.linalg.norm(across) <= 1e-9 * np.linalg.norm(a[1] - a[0]):
            self._fail("attachment_line", self.attachment_line,
                       "a line not parallel to the central fibre")
        if self.attenuation_start is not None:
            self._check("attenuation_start", 0.0, 0.5 * self.width_value)
        if self.fall_start is not None:
            self._check("fall_start", 0.0, self.length_value, lo_open=True, hi_open=True)
        elif self.fall_start_value >= self.length_value:
            self._fail("length", self.length_value,
                       f"(|m_Ic - m_Ac| = {self.fall_start_value:g}, inf)",
                       "The insertion line must lie inside the AOI, or give fall_start")
        self._check_strength()

    @classmethod
    def create(cls, name, at, skin, skull=None) -> SheetMuscle:
        """A 16 mm wide sheet from the skull above ``at`` to ``at`` on the skin
        (:meth:`Muscle.create`).
        """
        ins, att = anchor(skin, skull, at)
        across = np.array([8.0, 0.0, 0.0])
        ins_line = closest_points(skin, np.array([ins - across, ins + across]))
        att_line = closest_points(skull or skin, np.array([att - across, att + across]))
        return cls(name, attachment_line=tuple(map(tuple, att_line)),
                   insertion_line=tuple(map(tuple, ins_line)), lambda_w=0.3, n_wrinkles=3,
                   k0=2.0)

    @property
    def attachment_center(self) -> np.ndarray:
        """``(3,)``: :math:`m_{Ac}`."""
        return np.mean(self.attachment_line, axis=0)

    @property
    def insertion_center(self) -> np.ndarray:
        """``(3,)``: :math:`m_{Ic}`."""
        return np.mean(self.insertion_line, axis=0)

    @cached_property  # frozen: computed once per muscle
    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``((3,), (3,), (3,))``: the orthonormal fibre, across and normal axes f, s, n."""
        f = _unit(self.insertion_center - self.attachment_center)
        a = np.subtract(self.attachment_line[1], self.attachment_line[0])
        s = _unit(a - (a @ f) * f)
        axes = (f, s, np.cross(f, s))
        for axis in axes:
            axis.setflags(write=False)  # cached: shared by every caller
        return axes

    @property
    def fibre_length(self) -> float:
        r""":math:`\|m_{Ic} - m_{Ac}\|`."""
        return float(np.linalg.norm(self.insertion_center - self.attachment_center))

    @property
    def length_value(self) -> float:
        """:math:`L_s` actually used (the default resolved)."""
        return 1.25 * self.fibre_length if self.length is None else self.length

    @cached_property  # frozen: computed once per muscle
    def width_value(self) -> float:
        """:math:`W_s` actually used (the default resolved)."""
        if self.width is not None:
            return self.width
        _, s, _ = self.frame
        spans = [abs(np.subtract(line[1], line[0]) @ s)
                 for line in (self.attachment_line, self.insertion_line)]
        return float(max(spans))

    @property
    def depth_value(self) -> float:
        """The AOI's depth bound actually used (the default resolved)."""
        return 0.5 * max(self.length_value, self.width_value) if self.depth is None \
            else self.depth

    @property
    def fall_start_value(self) -> float:
        """:math:`R_s` actually used (the default resolved)."""
        return self.fibre_length if self.fall_start is None else self.fall_start

    @property
    def wrinkle_length(self) -> float:
        """:math:`L_s`, which replaces :math:`R` in Eq. 6 and 7."""
        return self.length_value

    @property
    def attenuation_start_value(self) -> float:
        """:math:`h^c` actually used (default :math:`W_s / 4`)."""
        start = self.attenuation_start
        return 0.25 * self.width_value if start is None else start

    @property
    def attenuation_range(self) -> tuple[float, float]:
        """``(h_c, W_s / 2)`` (Eq. 15)."""
        return (self.attenuation_start_value, 0.5 * self.width_value)

    def _geometry(self, points: np.ndarray) -> Geometry:
        f, s, n = self.frame
        v = points - self.attachment_center
        l = v @ f
        h = np.abs(v @ s)
        depth = v @ n
        lam = l / self.length_value
        gamma = 2.0 * h / self.width_value
        in_aoi = ((lam >= -_TOL) & (lam <= 1 + _TOL) & (gamma <= 1 + _TOL)
                  & (np.abs(depth) <= self.depth_value * (1 + _TOL)))
        direction = np.broadcast_to(-f, points.shape).copy()
        return Geometry(l=l, lam=lam, gamma=gamma, coordinate=h, in_aoi=in_aoi,
                        direction=direction, extra={"h": h, "depth": depth})

    def aoi_ball(self) -> tuple[np.ndarray, float]:
        r"""The ball around the AOI's box, :math:`0 \le l \le L_s`,
        :math:`|h| \le W_s/2`, :math:`|d| \le D` (:meth:`Muscle.aoi_ball`).
        """
        f, _, _ = self.frame
        half = 0.5 * self.length_value
        return slack_ball(self.attachment_center + half * f,
                          math.sqrt(half**2 + (0.5 * self.width_value)**2
                                    + self.depth_value**2))

    def hidden(self, points, skin) -> np.ndarray:
        r"""``(k,) bool``: which of the AOI's ``points`` ``(k, 3)`` lie behind another layer
        of ``skin``, seen from outside along the sheet's normal (our extension, with the
        depth bound): the ray :math:`x + t\,n_o`, :math:`t > \max(W_s/2,\ 2\bar e)`, meets
        the skin, with :math:`n_o = \pm n` pointing out of the head (away from the skin's
        centroid at the insertion line) and :math:`\bar e` the skin's mean edge length.

        The AOI's prism reaches through everything in its depth bound: on a scan with open
        eye sockets the frontalis wrinkled the roof of a socket 25 mm behind the forehead.
        A fold of the skin in the sheet's own footprint (a brow over a lid, a temple's
        hollow: skin a few millimetres behind skin) is not another layer, so the ray starts
        half the sheet's width out; skin that faces the sheet is never hidden.
        """
        _, _, n = self.frame
        outward = n if (self.insertion_center - skin.points.mean(axis=0)) @ n >= 0 else -n
        beyond = max(0.5 * self.width_value, HIDDEN_EDGES * skin.mean_edge_length)
        return occluded(skin, points, outward, beyond)

    def _falloff(self, points: np.ndarray, geometry: Geometry) -> np.ndarray:
        across = plateau_fall(geometry.extra["h"], *self.attenuation_range)
        depth = self.depth_value
        through = plateau_fall(geometry.extra["depth"], 0.5 * depth, depth)
        return across * through * ramp_fall(geometry.l, self.fall_start_value,
                                             self.length_value)
