"""The muscle base class: parameter validation, the wrinkling region and serialization.

A muscle type subclasses :class:`Muscle` (a frozen dataclass), implements
:meth:`Muscle._geometry` and :meth:`Muscle._falloff`, and registers itself with
:func:`wrinkle_vis.register_muscle_type`. Everything that follows from the geometry, the
wrinkling region (Eq. 3, 14), :math:`w` (Eq. 7), :math:`H` (Eq. 5), :math:`At` (Eq. 12, 15) and
the Waters-style displacement, is computed here once for every type.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import KW_ONLY, dataclass
from typing import Any, ClassVar

import numpy as np

from .equations import attenuation, bulge_height, half_period, periodic_coordinate, shape_function
from .params import (
    PARAMETER_KEY,
    Parameter,
    ParameterValueError,
    control_character,
    format_value,
    parameter,
)

__all__ = ["COMPRESSION_MEASURES", "MAX_COORDINATE", "OPTIONS", "Geometry", "Muscle",
           "MuscleParameterError", "MuscleRegion", "Parameter", "parameter", "plateau_fall",
           "ramp_fall", "smooth_fall", "waters_radial"]

#: The values of a muscle's ``compression`` option: ``"edges"`` is the paper's Eq. 10 (the
#: default), ``"gradient"`` the deformation gradient's stretch along the contraction
#: direction (:func:`~wrinkle_vis.core.equations.gradient_compression`).
COMPRESSION_MEASURES = ("edges", "gradient")

#: The options every muscle type has, off by default (``docs/model.md``, "Two options, off by
#: default"), with their allowed values, the default first.
OPTIONS = {"taper": (False, True), "compression": COMPRESSION_MEASURES}

#: The largest coordinate of a point parameter and the largest length parameter, in the
#: face's units: far beyond any face (1e12 mm is 7 times the Earth's orbit), yet its square
#: and products stay finite, so nothing overflows to inf.
MAX_COORDINATE = 1e12
#: The least value of a parameter that must be above 0 (an angle in degrees, a length):
#: what is divided by it stays finite.
MIN_POSITIVE = 1e-9
#: The relative slack of :meth:`Muscle.aoi_ball` (the AOI's own bounds are tested exactly
#: afterwards: slack costs a few candidates, never a vertex).
BALL_SLACK = 0.01


class MuscleParameterError(ValueError):
    """A muscle parameter out of its allowed range; the message names muscle, parameter,
    value and range, and ``param`` holds the parameter's name (None if not one).
    """

    def __init__(self, message: str, param: str | None = None):
        super().__init__(message)
        self.param = param


@dataclass(frozen=True)
class Geometry:
    r"""Per-vertex geometry of a muscle, as a muscle type computes it.

    Attributes
    ----------
    l : (n,) float
        Distance from the attachment (point or line) along the central fibre.
    lam, gamma : (n,) float
        Length factor :math:`\lambda` and angular/width factor :math:`\gamma`.
    coordinate : (n,) float
        The attenuation coordinate: :math:`\varphi` in degrees or :math:`h`.
    in_aoi : (n,) bool
        The area of influence.
    direction : (n, 3) float
        Unit contraction direction (zero where undefined).
    extra : dict of str to (n,) float
        Type-specific named arrays (``angle_deg`` or ``h``, ``depth``...).
    """

    l: np.ndarray
    lam: np.ndarray
    gamma: np.ndarray
    coordinate: np.ndarray
    in_aoi: np.ndarray
    direction: np.ndarray
    extra: dict


class MuscleRegion(Mapping):
    """Everything a muscle defines on a set of rest points, as named ``(n,)`` arrays.

    Geometric quantities (``lam``, ``gamma``, ``l`` and the type's own, such as
    ``angle_deg`` or ``h``) are given everywhere. Model quantities are ``nan`` where the
    muscle does not define them: ``At`` and ``direction`` outside the area of influence,
    ``w`` and ``H`` outside the wrinkling region. Read them as ``region.H`` or
    ``region["H"]``.
    """

    def __init__(self, arrays: dict[str, np.ndarray]):
        self._arrays = arrays

    def __getitem__(self, key: str) -> np.ndarray:
        return self._arrays[key]

    def __iter__(self):
        return iter(self._arrays)

    def __len__(self) -> int:
        return len(self._arrays)

    def __getattr__(self, key: str) -> np.ndarray:
        try:
            return self.__dict__["_arrays"][key]
        except KeyError:
            raise AttributeError(key) from None


def smooth_fall(t) -> np.ndarray:
    r"""The C1 fall from 1 to 0 that every built-in fall-off uses.

    Parameters
    ----------
    t : (...) array_like
        Position in the fall, 0 at its start and 1 at its end (clipped to ``[0, 1]``).

    Returns
    -------
    (...) ndarray
        .. math:: s(t) = \cos^2\left(\frac{\pi}{2} t\right) = \frac{1 + \cos \pi t}{2},

        1 with zero slope at :math:`t = 0` and 0 with zero slope at :math:`t = 1`, so a
        displacement built from it has no kink where it starts or stops falling. Two of them
        facing each other add up to one, :math:`s(t) + s(1 - t) = 1`, so neighbouring sheets
        whose falls overlap exactly move the skin between them as one.
    """
    t = np.clip(np.asarray(t, dtype=float), 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(np.pi * t))


def waters_radial(x: np.ndarray, fall_start: float, end: float) -> np.ndarray:
    r"""Waters' (1987) radial fall-off made C1: 0 at the attachment, 1 at the fall start
    :math:`R_s`, 0 at the end :math:`R_f`, with zero slope at all three.

    Parameters
    ----------
    x : (n,) float
        Distance from the attachment.
    fall_start, end : float
        :math:`R_s` and :math:`R_f` with :math:`0 < R_s < R_f`.

    Returns
    -------
    (n,) float
        .. math::

            r(x) = \begin{cases}
                \sin^2\left(\frac{x}{R_s}\frac{\pi}{2}\right) & 0 \le x \le R_s\\
                \cos^2\left(\frac{x - R_s}{R_f - R_s}\frac{\pi}{2}\right)
                    & R_s < x \le R_f \\
                0 & \text{otherwise}
            \end{cases}

    Notes
    -----
    Waters' own profile is the square root of this one, :math:`\cos((1 - x/R_s)\pi/2)`
    and :math:`\cos((x - R_s)/(R_f - R_s)\,\pi/2)`: the same rise and fall, but its slope
    jumps at :math:`0` and :math:`R_f`, which creases the skin where the pull begins and ends
    (``docs/model.md``).
    """
    x = np.asarray(x, dtype=float)
    rising = smooth_fall(1.0 - x / fall_start)
    falling = smooth_fall((x - fall_start) / (end - fall_start))
    out = np.where(x <= fall_start, rising, falling)
    return np.where((x >= 0.0) & (x <= end), out, 0.0)


def ramp_fall(x, peak: float, end: float) -> np.ndarray:
    r"""``(n,)``: a uniform squeeze up to ``peak`` and a C1 fall to 0 at ``end``.

    Parameters
    ----------
    x : (n,) float
        Distance from the attachment along the fibre.
    peak, end : float
        Where the profile reaches 1 (:math:`R_s`) and 0 again (:math:`L_s`),
        :math:`0 < R_s < L_s`.

    Returns
    -------
    (n,) float
        0 at :math:`x = 0`, rising with the constant slope :math:`m = 1/(R_s - \sigma)` between
        two C1 shoulders of width :math:`\sigma = \min(L_s - R_s, R_s)/2`, 1 at :math:`R_s`,
        then :func:`smooth_fall` over :math:`[R_s, L_s]`:

        .. math::

            r(x) = \begin{cases}
                m x^2 / (2\sigma) & 0 \le x \le \sigma \\
                m (x - \sigma/2) & \sigma < x \le R_s - \sigma \\
                1 - m (R_s - x)^2 / (2\sigma) & R_s - \sigma < x \le R_s \\
                s\left(\frac{x - R_s}{L_s - R_s}\right) & R_s < x \le L_s \\
                0 & \text{otherwise.}
            \end{cases}

    Notes
    -----
    The pull of a sheet along its fibres. Skin pulled towards a line of attachment is
    compressed where the pull grows along the fibre; a constant slope compresses the whole
    wrinkling region alike, so each of its :math:`n_w` wrinkles appears, where Waters' radial
    rise (:func:`waters_radial`) would leave the wrinkles near the peak flat.
    """
    x = np.asarray(x, dtype=float)
    sigma = min(0.5 * (end - peak), 0.5 * peak)
    m = 1.0 / (peak - sigma)
    rise = np.where(x <= sigma, 0.5 * m * x * x / sigma,
                    np.where(x <= peak - sigma, m * (x - 0.5 * sigma),
                             1.0 - 0.5 * m * (peak - x) ** 2 / sigma))
    out = np.where(x <= peak, rise, smooth_fall((x - peak) / (end - peak)))
    return np.where((x >= 0.0) & (x <= end), out, 0.0)


def plateau_fall(x, start: float, end: float) -> np.ndarray:
    r"""``(n,)``: 1 up to ``start``, then :func:`smooth_fall` to 0 at ``end`` (C1).

    .. math::

        p(x) = \begin{cases} 1 & |x| \le x_c \\
                             s\left(\frac{|x| - x_c}{x_e - x_c}\right) & x_c < |x| \le x_e\\
                             0 & \text{otherwise} \end{cases}

    The across-fibre and depth fall-off of a sheet, and the C1 twin of Eq. 15's profile
    (:func:`~wrinkle_vis.core.equations.attenuation`, which stays the wrinkles' ``At``).
    """
    x = np.abs(np.asarray(x, dtype=float))
    if end <= start:
        return np.where(x <= end, 1.0, 0.0)
    return smooth_fall((x - start) / (end - start))


class _FromParameters:
    """A class attribute computed from the declared parameters (:meth:`Muscle.parameters`):
    ``point_parameters`` and ``length_parameters``. A subclass may still set a tuple by hand
    (a plug-in written before parameters carried metadata).
    """

    def __init__(self, pick):
        self._pick = pick

    def __set_name__(self, owner, name):
        self._name = name

    def __get__(self, obj, cls=None) -> tuple[str, ...]:
        cls = type(obj) if cls is None else cls
        if not hasattr(cls, "__dataclass_fields__"):  # while @dataclass reads the class
            return self  # type: ignore[return-value]  # the descriptor, not a value yet
        return tuple(p.name for p in cls.parameters() if self._pick(p))


@dataclass(frozen=True)
class Muscle:
    r"""Base class of every muscle type (linear, sheet, and plug-ins).

    Subclasses are frozen dataclasses whose first field is ``name``. Each parameter is a
    field made by :func:`~wrinkle_vis.core.params.parameter`, which carries its metadata
    (:class:`~wrinkle_vis.core.params.Parameter`: label, symbol, unit, range, step, whether
    it is derived when left out, and for a point the surface it lies on); validation, the
    app's parameter panel, layout files, the command line and the documentation read that
    metadata (:meth:`parameters`). Subclasses set the class attribute ``type_name`` (the
    registry key) and implement ``_geometry``, ``_falloff``, ``wrinkle_length`` and
    ``attenuation_range``, and may implement :meth:`create` (a new muscle placed at a point
    of the skin).

    A type may declare its placement widget as ``widget = "package.module:Factory"`` and its
    glyph as ``glyph = "package.module:function"`` (strings, so the core never imports VTK);
    :func:`wrinkle_vis.widgets.widget_factory` and :func:`wrinkle_vis.plotting.glyph_factory`
    look them up along the class hierarchy, and a type with none gets a generic widget with a
    handle per point parameter and a generic glyph through its points.

    The base class declares the wrinkle parameters every type shares, keyword-only:

    Parameters
    ----------
    lambda_w : float, default 0.5
        :math:`\lambda_w \in [0, 1)`; the wrinkling region is
        :math:`\lambda_w \le \lambda \le 1`.
    n_wrinkles : int, default 3
        :math:`n_w \ge 1`, the number of wrinkles along the central fibre (Eq. 6).
    k0 : float, default 0.5
        Furrow depth factor :math:`k_0 \ge 0` (face units).
    alpha : float, default 1.0
        Shape modulation :math:`\alpha \in [-1, 10]`; :math:`\alpha > 0` gives a sharp
        furrow and a round bulge.
    strength : float, optional
        Peak displacement :math:`K` at activation 1 (face units); default
        :attr:`strength_value`. Types bounded by Waters' fall start :math:`R_s` check
        :math:`K < 2 R_s / \pi` (:meth:`_check_strength`).

    and two options (:data:`OPTIONS`), off by default so that the paper's model is what a
    muscle computes unless asked otherwise:

    taper : bool, default False
        Multiply :math:`H` by a C1 taper over the first and the last half period of the
        wrinkling region (:meth:`taper_profile`), so that it rises from 0 where the region
        starts and falls back to 0 where it ends instead of jumping to the furrow bottom.
    compression : {"edges", "gradient"}, default "edges"
        How :math:`\varepsilon` is measured: ``"edges"`` is Eq. 10 (with :math:`|\cos|`
        weights); ``"gradient"`` is the deformation gradient's stretch along the contraction
        direction, exact for a uniform strain
        (:func:`~wrinkle_vis.core.equations.gradient_compression`).
    """

    type_name: ClassVar[str] = ""
    widget: ClassVar[str | None] = None
    glyph: ClassVar[str | None] = None
    #: Names of the point (and line) parameters, from the metadata.
    point_parameters = _FromParameters(lambda p: p.is_point)
    #: Names of the parameters that are lengths (they scale with the face).
    length_parameters = _FromParameters(lambda p: p.is_length)

    name: str
    _: KW_ONLY  # as every parameter() is by default (said here for type checkers)
    taper: bool = parameter(
        False, label="taper H at the ends", symbol="T", unit="option",
        choices=OPTIONS["taper"],
        doc="Remove the seam at the ends of the wrinkling region: the paper's Eq. 5 (off) "
            "jumps from no wrinkle to the furrow bottom where the region starts and ends, "
            "which shows as a line (e.g. across the top of the forehead's wrinkles); on, "
            "H tapers to 0, C1, over the region's first and last half period")
    compression: str = parameter(
        "edges", label="eps from", symbol="ε", unit="option", choices=OPTIONS["compression"],
        choice_labels=("edges (Eq. 10)", "gradient"),
        doc="How eps is measured: the paper's Eq. 10 over the edges, or the deformation "
            "gradient's stretch along the contraction direction (exact for a uniform strain)")
    lambda_w: float = parameter(
        0.5, label="lambda_w", symbol="λ_w", unit="1", lo=0.0, hi=1.0, hi_open=True,
        step=0.05, doc="where the wrinkling region starts, as a fraction of the length")
    n_wrinkles: int = parameter(
        3, label="n_w", symbol="n_w", unit="count", lo=1, step=1,
        doc="the number of wrinkles along the central fibre (Eq. 6)")
    k0: float = parameter(
        0.5, label="k0", symbol="k_0", unit="length", lo=0.0, step=0.1,
        doc="furrow depth factor (Eq. 5, 8)")
    alpha: float = parameter(
        1.0, label="alpha", symbol="α", unit="1", lo=-1.0, hi=10.0, step=0.1,
        hint="alpha < -1 turns the furrow into a crest",
        doc="shape modulation: > 0 gives a sharp furrow and a round bulge (Eq. 5)")
    strength: float | None = parameter(
        label="K", symbol="K", unit="length", lo=0.0, step=0.5, derived="strength_value",
        doc="peak skin displacement at activation 1")

    # ------------------------------------------------------------ the declared parameters
    @classmethod
    def parameters(cls) -> tuple[Parameter, ...]:
        """Every parameter but ``name`` and the options, in declaration order (the type's
        own first, then the shared wrinkle parameters), with its metadata.

        A field declared without :func:`~wrinkle_vis.core.params.parameter` gets plain
        metadata: its name as label and symbol, a point if the class lists it in
        ``point_parameters`` by hand, a length if in ``length_parameters``.
        """
        cached = cls.__dict__.get("_parameters_cache")
        if cached is not None:
            return cached
        base = {f.name for f in dataclasses.fields(Muscle)}
        fields = [f for f in dataclasses.fields(cls) if f.name != "name" and
                  f.name not in OPTIONS]
        ordered = [f for f in fields if f.name not in base] + [f for f in fields
                                                               if f.name in base]
        out = tuple(_metadata(cls, f) for f in ordered)
        type.__setattr__(cls, "_parameters_cache", out)
        return out

    @classmethod
    def options(cls) -> tuple[Parameter, ...]:
        """The :data:`OPTIONS` every type has, with their metadata (label, choices, doc)."""
        cached = cls.__dict__.get("_options_cache")
        if cached is None:
            fields = {f.name: f for f in dataclasses.fields(cls)}
            cached = tuple(_metadata(cls, fields[name]) for name in OPTIONS)
            type.__setattr__(cls, "_options_cache", cached)
        return cached

    @classmethod
    def parameter(cls, name: str) -> Parameter:
        """The metadata of parameter (or option) ``name``; ``KeyError`` lists the type's
        parameters.
        """
        for p in (*cls.parameters(), *cls.options()):
            if p.name == name:
                return p
        raise KeyError(f"{cls.type_name or cls.__name__} muscles have no parameter {name!r}; "
                       f"they have: {', '.join(p.name for p in cls.parameters())}")

    @classmethod
    def point_surfaces(cls) -> dict[str, str]:
        """``{point parameter: "skin" or "skull"}`` (a point with no surface: the skin)."""
        return {p.name: p.surface or "skin" for p in cls.parameters() if p.is_point}

    def resolved(self, name: str):
        """The value parameter ``name`` takes: its own, or for an optional parameter left
        out (None), the value derived from the others (:attr:`Parameter.derived`).
        """
        spec = self.parameter(name)
        value = getattr(self, name)
        if value is None and spec.derived:
            return getattr(self, spec.derived)
        return value

    @classmethod
    def create(cls, name: str, at, skin, skull=None) -> Muscle:
        """A new muscle called ``name`` with its insertion on ``skin`` at ``at`` ``(3,)``,
        ready to be dragged into place (the app's Add muscle).

        Parameters
        ----------
        name : str
            Its name.
        at : (3,) array_like
            A point at or near the skin.
        skin, skull : TriangleSurface
            The surfaces its points go on (``skull`` None: the skin).

        Raises
        ------
        NotImplementedError
            When the type does not know how to make one; the message says what to do.
        """
        raise NotImplementedError(
            f"the {cls.type_name!r} muscle type cannot create a new muscle; load one from a "
            "layout file, or give the type a create() class method")

    # ------------------------------------------------------------ validation helpers
    def _fail(self, param: str, value, allowed: str, hint: str = "") -> None:
        kind = self.type_name or type(self).__name__
        msg = (
            f"{kind} muscle {self.name!r}: parameter {param} = {format_value(value)} is invalid; "
            f"allowed: {allowed}"
        )
        raise MuscleParameterError(msg + (f". {hint}" if hint else ""), param)

    def _check(self, param, lo=-math.inf, hi=math.inf, *, lo_open=False, hi_open=False,
               hint="") -> float:
        """Check the number ``param`` against a range that depends on other parameters."""
        return self._validated(Parameter(name=param), hint, lo, hi, lo_open=lo_open,
                               hi_open=hi_open)

    def _validated(self, spec: Parameter, hint: str = "", *bounds, **open_bounds):
        """``spec``'s value through :meth:`Parameter.validate` (stored converted), or the
        muscle's one-line error.
        """
        value = getattr(self, spec.name)
        try:
            x = spec.validate(value, *bounds, **open_bounds)
        except ParameterValueError as e:
            self._fail(spec.name, value, e.allowed, e.hint or hint)
        object.__setattr__(self, spec.name, x)
        return x

    def _check_point(self, param, shape=(3,)) -> np.ndarray:
        value = getattr(self, param)
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError, OverflowError):
            self._fail(param, value, f"finite coordinates of shape {shape}")
        if np.isfinite(arr).all() and np.abs(arr).max(initial=0.0) > MAX_COORDINATE:
            self._fail(param, value, f"coordinates within +-{MAX_COORDINATE:.0e}")
        if arr.shape != shape or not np.isfinite(arr).all():
            self._fail(param, value, f"finite coordinates of shape {shape}")
        as_tuple = tuple(map(float, arr)) if arr.ndim == 1 else tuple(
            tuple(map(float, row)) for row in arr
        )
        object.__setattr__(self, param, as_tuple)
        return arr

    def _check_common(self) -> None:
        """Validate the name, the options and every declared parameter against its
        metadata (:meth:`parameters`); checks that involve several parameters are the
        type's own, in its ``__post_init__``.
        """
        if not isinstance(self.name, str) or not self.name.strip():
            raise MuscleParameterError(
                f"{self.type_name} muscle: name must be a non-empty string; got {self.name!r}"
            )
        bad = control_character(self.name)
        if bad is not None:
            raise MuscleParameterError(
                f"{self.type_name} muscle {self.name!r}: name holds the control character "
                f"{bad}; use printable characters (any language) only", "name")
        self._check_options()
        for spec in self.parameters():
            self._check_declared(spec)

    def _check_declared(self, spec: Parameter) -> None:
        """Check one parameter against its metadata: shape, integer, static range."""
        if not spec.label or (spec.optional and getattr(self, spec.name) is None):
            return  # undeclared (no metadata), or left to its derived value
        if spec.unit in ("point", "vector"):
            self._check_point(spec.name, spec.shape or (3,))
        elif spec.unit == "count":
            self._validated(spec)
        elif spec.is_number:
            x = self._validated(spec, spec.hint)
            if spec.is_length and abs(x) > MAX_COORDINATE:
                self._fail(spec.name, x, f"at most {MAX_COORDINATE:g} (face units)",
                           "Far beyond any face: check the value and the layout's unit")
            if spec.lo == 0.0 and spec.lo_open and x < MIN_POSITIVE:
                self._fail(spec.name, x, f"{spec.range_text()}, at least {MIN_POSITIVE:g}",
                           "A value this close to 0 overflows what is divided by it")

    def _check_options(self) -> None:
        """Validate :data:`OPTIONS`: ``taper`` a bool, ``compression`` a known measure."""
        for spec in self.options():
            value = getattr(self, spec.name)
            if spec.is_flag:
                if not isinstance(value, (bool, np.bool_)):
                    self._fail(spec.name, value, "True or False")
                object.__setattr__(self, spec.name, bool(value))
            elif not isinstance(value, str) or value not in spec.choices:
                self._fail(spec.name, value, " or ".join(map(repr, spec.choices)))

    def _check_strength(self) -> None:
        r"""Validate ``strength`` against Waters' fall start: below :math:`2 R_s / \pi`."""
        if self.strength is not None:
            self._check("strength", 0.0, 2.0 * self.fall_start_value / math.pi, hi_open=True,
                        hint="a stronger pull would drag skin past the attachment")

    @property
    def strength_value(self) -> float:
        """:math:`K` actually used: ``strength``, by default :math:`0.2 R_s`."""
        return 0.2 * self.fall_start_value if self.strength is None else self.strength

    # ------------------------------------------------------------ to be implemented
    @property
    def fall_start_value(self) -> float:
        r""":math:`R_s`, Waters' fall start: where the pull peaks (:attr:`strength_value`
        defaults to :math:`0.2 R_s`, :meth:`_check_strength` bounds it by :math:`2 R_s /
        \pi`). A type whose :attr:`strength_value` does not use it need not define it.
        """
        raise NotImplementedError(f"{type(self).__name__} defines no fall_start_value "
                                  "(R_s); define it, or strength_value")

    @property
    def wrinkle_length(self) -> float:
        """:math:`R` (linear) or :math:`L_s` (sheet): the length in Eq. 6 and 7."""
        raise NotImplementedError

    @property
    def attenuation_range(self) -> tuple[float, float]:
        """``(start, end)`` of the attenuation coordinate (Eq. 12 or 15)."""
        raise NotImplementedError

    def _geometry(self, points: np.ndarray) -> Geometry:
        raise NotImplementedError

    def _falloff(self, points: np.ndarray, geometry: Geometry) -> np.ndarray:
        """``(n,)``: Waters-style displacement magnitude per unit activation."""
        raise NotImplementedError

    # ------------------------------------------------------------ derived parameters
    @property
    def u(self) -> float:
        """Half period :math:`u` of the wrinkles (Eq. 6)."""
        return half_period(self.lambda_w, self.wrinkle_length, self.n_wrinkles)

    @property
    def d(self) -> float:
        """Bulge height :math:`d` (Eq. 8)."""
        return bulge_height(self.k0, self.alpha)

    def taper_profile(self, l) -> np.ndarray:
        r"""The longitudinal taper of :math:`H` (the ``taper`` option), at distances ``l``.

        Parameters
        ----------
        l : (n,) array_like
            Distance from the attachment along the central fibre.

        Returns
        -------
        (n,) ndarray
            With :math:`s = l - \lambda_w R` the distance into the wrinkling region,
            :math:`L_r = (1 - \lambda_w) R` its length and :math:`u` the half period (Eq. 6),

            .. math::

                T(s) = \rho\!\left(\frac{s}{u}\right)\rho\!\left(\frac{L_r - s}{u}\right),
                \qquad \rho(t) = \sin^2\!\left(\frac{\pi}{2}\,
                \operatorname{clip}(t, 0, 1)\right) = 1 - \operatorname{smooth\_fall}(t),

            0 with zero slope at both ends of the region, 1 (also with zero slope) from one
            half period in to one half period before the end. :math:`T H` is C1 across the
            region's ends, where :math:`H` alone jumps from 0 to the furrow bottom
            :math:`d - k_0 2^\alpha`.
        """
        u = self.u
        s = np.asarray(l, dtype=float) - self.lambda_w * self.wrinkle_length
        span = (1.0 - self.lambda_w) * self.wrinkle_length
        return (1.0 - smooth_fall(s / u)) * (1.0 - smooth_fall((span - s) / u))

    # ------------------------------------------------------------ the model
    def region(self, rest_points) -> MuscleRegion:
        r"""The muscle's fields on rest points.

        Parameters
        ----------
        rest_points : (n, 3) array_like
            Rest positions of the skin vertices.

        Returns
        -------
        MuscleRegion
            ``lam``, ``gamma``, ``l`` and type-specific geometry everywhere; ``in_aoi`` and
            ``in_region`` (Eq. 3 or 14: the AOI where :math:`\lambda_w \le \lambda` and
            :math:`\gamma \le 1`); ``At`` and ``direction`` on the AOI; ``w`` (Eq. 7)
            and ``H`` (Eq. 5; times :meth:`taper_profile` with the ``taper`` option) on the
            wrinkling region, ``nan`` elsewhere.
        """
        p = _points(rest_points)
        g = self._geometry(p)
        in_region = g.in_aoi & (g.lam >= self.lambda_w - 1e-9) & (g.gamma <= 1.0 + 1e-6)
        start, end = self.attenuation_range
        at = np.where(g.in_aoi, attenuation(g.coordinate, start, end), np.nan)
        w = np.where(
            in_region,
            periodic_coordinate(g.l, self.lambda_w, self.wrinkle_length, self.n_wrinkles),
            np.nan,
        )
        h = shape_function(w, self.u, self.k0, self.alpha)
        if self.taper:
            h = h * self.taper_profile(g.l)
        direction = np.where(g.in_aoi[:, None], g.direction, np.nan)
        arrays = dict(lam=g.lam, gamma=g.gamma, l=g.l, **g.extra)
        arrays.update(in_aoi=g.in_aoi, in_region=in_region, w=w, H=h, At=at,
                      direction=direction)
        return MuscleRegion(arrays)

    def aoi_ball(self) -> tuple[np.ndarray, float] | None:
        """``((3,), float)``: the centre and radius of a ball that holds the whole area of
        influence (with some slack), or None where the type cannot bound it (every point
        is then a candidate). A face evaluates :meth:`region` only on the skin vertices in
        the ball (:meth:`candidates`), which on a big scan is a small part of it; a bound
        that is too tight loses vertices, one too loose only costs time.
        """
        return None

    def candidates(self, skin) -> np.ndarray:
        """``(c,)``: the ids, ascending, of the vertices of ``skin`` (a
        :class:`~wrinkle_vis.core.mesh.TriangleSurface`) that may lie in the area of
        influence: those in :meth:`aoi_ball`, all without one.

        One pass of squared distances over the vertices (a few milliseconds on a million;
        building a k-d tree of them takes longer than every muscle's pass together).
        """
        ball = self.aoi_ball()
        if ball is None:
            return np.arange(skin.n_points)
        centre, radius = ball
        d = skin.points - np.asarray(centre, float)
        return np.flatnonzero(np.einsum("ij,ij->i", d, d) <= float(radius) ** 2)

    def hidden(self, points, skin) -> np.ndarray:
        """``(k,) bool``: which of ``points`` ``(k, 3)`` (rest points of the AOI) lie on skin
        that the muscle cannot reach, with the rest skin ``skin`` (a
        :class:`~wrinkle_vis.core.mesh.TriangleSurface`) to tell; the face leaves them out
        of the AOI. None here; a type whose AOI is a volume that can take in skin facing
        away from it says which (:meth:`SheetMuscle.hidden
        <wrinkle_vis.core.muscles.SheetMuscle.hidden>`).
        """
        return np.zeros(len(np.atleast_2d(points)), bool)

    def unit_displacement(self, rest_points) -> np.ndarray:
        """``(n, 3)``: the displacement at activation 1 (see :meth:`displacement`)."""
        p = _points(rest_points)
        g = self._geometry(p)
        mag = np.where(g.in_aoi, self._falloff(p, g), 0.0)
        return self.strength_value * mag[:, None] * g.direction

    def displacement(self, rest_points, activation: float) -> np.ndarray:
        """Waters-style skin displacement, ``(n, 3)``, linear in the activation.

        Parameters
        ----------
        rest_points : (n, 3) array_like
            Rest positions.
        activation : float
            Contraction in ``[0, 1]``.
        """
        a = check_activation(self.name, activation)
        return a * self.unit_displacement(rest_points)

    # ------------------------------------------------------------ serialization
    def to_dict(self) -> dict[str, Any]:
        """A plain, JSON-ready dict: ``{"type": type_name, "name": ..., parameters...,
        options...}`` (the :data:`OPTIONS` last; a dict without them gets their defaults).
        """
        out: dict[str, Any] = {"type": self.type_name}
        for name in ["name", *(p.name for p in self.parameters()), *OPTIONS]:
            out[name] = _plain(getattr(self, name))
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Muscle:
        """Build a muscle from :meth:`to_dict` output; unknown keys are an error."""
        data = dict(data)
        kind = data.pop("type", cls.type_name)
        if kind != cls.type_name:
            raise MuscleParameterError(
                f"cannot build a {cls.type_name!r} muscle from a dict of type {kind!r}"
            )
        names = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(data) - set(names))
        if unknown:
            raise MuscleParameterError(
                f"{cls.type_name} muscle {data.get('name')!r}: unknown parameter(s) "
                f"{', '.join(unknown)}; known: {', '.join(names)}"
            )
        required = [
            f.name for f in dataclasses.fields(cls)
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        ]
        missing = [n for n in required if n not in data]
        if missing:
            raise MuscleParameterError(
                f"{cls.type_name} muscle {data.get('name')!r}: missing parameter(s) "
                f"{', '.join(missing)}"
            )
        return cls(**data)

    def transformed(self, transform, scale: float = 1.0) -> Muscle:
        """A copy whose point parameters go through ``transform`` (``(k, 3) -> (k, 3)``)
        and whose length parameters are multiplied by ``scale``.
        """
        changes = {}
        for param in self.point_parameters:
            arr = np.asarray(getattr(self, param), dtype=float)
            changes[param] = np.asarray(transform(arr.reshape(-1, 3))).reshape(arr.shape)
        for param in self.length_parameters:
            value = getattr(self, param)
            if value is not None:
                changes[param] = scale * value
        return self.replace(**changes)

    def replace(self, **changes) -> Muscle:
        """A copy with some parameters changed (validated again)."""
        return dataclasses.replace(self, **changes)


def _metadata(cls, f) -> Parameter:
    """The :class:`Parameter` of field ``f`` of ``cls``, with its name filled in."""
    spec = f.metadata.get(PARAMETER_KEY)
    if spec is not None:
        return dataclasses.replace(spec, name=f.name)
    if f.name in _by_hand(cls, "point_parameters"):
        return Parameter(name=f.name, unit="point", shape=(3,))
    unit = "length" if f.name in _by_hand(cls, "length_parameters") else "1"
    return Parameter(name=f.name, unit=unit)


def _by_hand(cls, attribute: str) -> tuple[str, ...]:
    """``point_parameters`` or ``length_parameters`` as a class sets them by hand."""
    for c in cls.__mro__:
        value = c.__dict__.get(attribute)
        if value is not None and not isinstance(value, _FromParameters):
            return tuple(value)
    return ()


def check_activation(name: str, activation) -> float:
    """Validate one activation; returns it as a float in ``[0, 1]``."""
    try:
        a = float(activation)
    except (TypeError, ValueError):
        raise ValueError(
            f"activation of muscle {name!r} must be a number in [0, 1]; got {activation!r}"
        ) from None
    if not (0.0 <= a <= 1.0):
        raise ValueError(f"activation of muscle {name!r} = {a:g} is outside [0, 1]")
    return a


def slack_ball(centre, radius: float) -> tuple[np.ndarray, float]:
    """``((3,), float)``: the ball ``centre``, ``radius`` grown by :data:`BALL_SLACK` of its
    radius and of the centre's distance from the origin (rounding in the AOI's own tests).
    """
    c = np.asarray(centre, float)
    grow = BALL_SLACK * (radius + float(np.linalg.norm(c)))
    return c, float(radius) + grow


def _points(points) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"rest_points must have shape (n, 3); got {p.shape}")
    return p


def _plain(value):
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
