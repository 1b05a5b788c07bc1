"""Each muscle type describes its parameters once (issue 16): metadata, checks, surfaces."""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass

import numpy as np
import pytest
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.core.editing import mirrored, snapped
from wrinkle_vis.core.mesh import TriangleSurface, closest_points
from wrinkle_vis.core.muscle import Geometry, Muscle, MuscleParameterError, parameter
from wrinkle_vis.core.params import Parameter

SHARED = ("lambda_w", "n_wrinkles", "k0", "alpha", "strength")


def _linear(**kw):
    return wv.LinearMuscle("m", (0, 0, 0), (0, 10, 0), **{"radius": 15.0,
                                                           "max_angle_deg": 30.0, **kw})


def _sheet(**kw):
    return wv.SheetMuscle("s", ((-5, 0, 0), (5, 0, 0)), ((-5, 10, 0), (5, 10, 0)), **kw)


@pytest.mark.parametrize("cls", [wv.LinearMuscle, wv.SheetMuscle])
def test_the_shared_parameters_are_declared_once_in_the_base_class(cls):
    own = cls.__dict__.get("__annotations__", {})
    assert not set(SHARED) & set(own)  # not declared again by the type
    names = [p.name for p in cls.parameters()]
    assert names[-len(SHARED):] == list(SHARED)  # the base's, after the type's own
    base = {p.name: p for p in Muscle.parameters()}
    for name in SHARED:
        assert cls.parameter(name) == base[name]
    assert cls.parameter("k0").unit == "length" and cls.parameter("n_wrinkles").unit == "count"


@pytest.mark.parametrize("cls", [wv.LinearMuscle, wv.SheetMuscle])
def test_every_parameter_carries_label_symbol_unit_and_doc(cls):
    for p in cls.parameters():
        assert p.label and p.symbol and p.doc, p
        assert p.label.isascii()  # VTK and the panel's font
        if p.is_point:
            assert p.surface in ("skin", "skull") and p.shape in ((3,), (2, 3))
        if p.optional:  # left out it takes a value derived from the others
            assert hasattr(cls, p.derived)


def test_point_and_length_parameters_follow_from_the_metadata():
    assert wv.LinearMuscle.point_parameters == ("attachment", "insertion")
    assert wv.LinearMuscle.point_surfaces() == {"attachment": "skull", "insertion": "skin"}
    assert wv.SheetMuscle.point_surfaces() == {"attachment_line": "skull",
                                               "insertion_line": "skin"}
    assert set(wv.LinearMuscle.length_parameters) == {"radius", "fall_start", "k0",
                                                      "strength"}
    m = _linear(fall_start=8.0, strength=2.0)
    t = m.transformed(lambda p: 2.0 * p, 2.0)  # a uniform scaling by 2
    for name in m.length_parameters:
        assert getattr(t, name) == pytest.approx(2.0 * getattr(m, name))
    assert t.max_angle_deg == m.max_angle_deg and t.alpha == m.alpha  # not lengths


@pytest.mark.parametrize("make", [_linear, _sheet])
def test_every_static_bound_is_checked_from_the_metadata(make):
    muscle = make()
    for p in type(muscle).parameters():
        if not p.is_number:
            continue
        for bound, is_open, step in ((p.lo, p.lo_open, -1.0), (p.hi, p.hi_open, 1.0)):
            if not math.isfinite(bound):
                continue
            bad = bound if is_open else bound + step * (0.5 if p.unit != "count" else 1)
            with pytest.raises(MuscleParameterError) as err:
                muscle.replace(**{p.name: bad})
            assert err.value.param == p.name
            assert f"parameter {p.name} = " in str(err.value)
            if p.unit != "count":
                assert p.range_text() in str(err.value)


def test_the_alpha_hint_comes_from_its_metadata():
    with pytest.raises(MuscleParameterError, match="alpha < -1 turns the furrow into a crest"):
        _linear(alpha=-2.0)


def test_resolved_gives_the_derived_value_of_a_parameter_left_out():
    m = _linear()
    assert m.fall_start is None and m.resolved("fall_start") == pytest.approx(10.0)
    assert m.resolved("strength") == pytest.approx(0.2 * 10.0)
    assert m.resolved("attenuation_start_deg") == pytest.approx(15.0)
    assert m.resolved("radius") == 15.0
    s = _sheet()
    assert s.resolved("length") == pytest.approx(12.5) and s.resolved("width") == 10.0
    assert s.resolved("attenuation_start") == pytest.approx(2.5)
    assert s.resolved("depth") == pytest.approx(0.5 * 12.5)
    with pytest.raises(KeyError, match="no parameter 'nope'; they have: attachment"):
        m.resolved("nope")


def test_a_new_type_is_one_class_and_its_metadata_checks_it():
    @dataclass(frozen=True)
    class Dot(Muscle):
        type_name = "dot_for_test"
        center: tuple = parameter(kw_only=False, label="c", symbol="c", unit="point",
                                  shape=(3,), surface="skin", doc="centre")
        _: KW_ONLY
        reach: float = parameter(5.0, label="r", symbol="r", unit="length", lo=0.0,
                                 lo_open=True, hi=50.0, doc="reach")

        def __post_init__(self):
            self._check_common()

        @property
        def fall_start_value(self):
            return 0.5 * self.reach

        wrinkle_length = property(lambda self: self.reach)
        attenuation_range = property(lambda self: (0.0, 1.0))

        def _geometry(self, points):
            d = np.linalg.norm(points - np.asarray(self.center), axis=1)
            return Geometry(l=d, lam=d / self.reach, gamma=np.zeros(len(d)), coordinate=d,
                            in_aoi=d <= self.reach, direction=np.zeros_like(points), extra={})

    dot = Dot("d", (0, 0, 0), reach=4.0)
    assert dot.center == (0.0, 0.0, 0.0) and dot.lambda_w == 0.5  # the shared defaults
    assert Dot.point_parameters == ("center",) and Dot.length_parameters == (
        "reach", "k0", "strength")
    with pytest.raises(MuscleParameterError, match=r"reach = 60 is invalid; allowed: \(0, 50\]"):
        Dot("d", (0, 0, 0), reach=60.0)
    with pytest.raises(MuscleParameterError, match="center"):
        Dot("d", (0, 0))
    with pytest.raises(MuscleParameterError, match=r"strength = 3 .*\[0, 1.59155\)"):
        Dot("d", (0, 0, 0), reach=5.0, strength=3.0).replace()._check_strength()
    assert Dot.from_dict(dot.to_dict()) == dot
    assert list(dot.to_dict())[:4] == ["type", "name", "center", "reach"]
    with pytest.raises(NotImplementedError, match="cannot create a new muscle"):
        Dot.create("x", (0, 0, 0), None)


def test_metadata_is_checked_when_declared():
    with pytest.raises(ValueError, match="unit 'mm' is not one of length"):
        Parameter(name="x", unit="mm")
    with pytest.raises(ValueError, match="surface 'bone' is not one of skin, skull"):
        Parameter(name="x", unit="point", shape=(3,), surface="bone")
    with pytest.raises(ValueError, match=r"needs shape \(3,\) or \(2, 3\)"):
        Parameter(name="x", unit="point")


def test_a_type_written_before_metadata_still_works():
    @dataclass(frozen=True)
    class Old(Muscle):
        point_parameters = ("tip",)
        length_parameters = ("size", "k0")
        tip: tuple = (0.0, 0.0, 0.0)
        size: float = 1.0

    assert Old.point_parameters == ("tip",)
    assert Old.point_surfaces() == {"tip": "skin"}
    assert Old.parameter("size").unit == "length" and Old.parameter("size").label == ""


# ---------------------------------------------------------------------- snapping, in core
def _plane(z: float) -> TriangleSurface:
    g = grid(11, 11, 60.0)
    return TriangleSurface(g.points + [0.0, 0.0, z], g.triangles)


def test_snapped_puts_each_point_on_its_declared_surface():
    skin, skull = _plane(0.0), _plane(-10.0)
    m = wv.LinearMuscle("m", (1, 2, -7), (3, 8, 2), radius=20.0, max_angle_deg=30.0)
    s = snapped(m, {"skin": skin, "skull": skull})
    assert s.attachment[2] == pytest.approx(-10.0) and s.insertion[2] == pytest.approx(0.0)
    assert s.attachment[:2] == pytest.approx((1, 2)) and s.insertion[:2] == pytest.approx((3, 8))
    # no skull: the skull's points go on the skin; a missing surface is skipped
    assert snapped(m, {"skin": skin, "skull": None}).attachment[2] == pytest.approx(0.0)
    only = snapped(m, {"skull": skull})
    assert only.insertion == m.insertion and only.attachment[2] == pytest.approx(-10.0)


def test_snapped_leaves_lines_when_asked_and_points_off_their_surface_in_like():
    skin, skull = _plane(0.0), _plane(-10.0)
    sheet = wv.SheetMuscle("s", ((-5, 0, -6), (5, 0, -6)), ((-5, 10, 1), (5, 10, 1)))
    assert snapped(sheet, {"skin": skin, "skull": skull}, lines=False) is sheet
    on = snapped(sheet, {"skin": skin, "skull": skull})
    assert np.allclose(np.asarray(on.attachment_line)[:, 2], -10.0)
    # like: the attachment line lay off the skull before (a shared frame): it stays
    like = sheet.replace(insertion_line=((-5, 10, 0), (5, 10, 0)))
    kept = snapped(sheet, {"skin": skin, "skull": skull}, like=like)
    assert kept.attachment_line == sheet.attachment_line
    assert np.allclose(np.asarray(kept.insertion_line)[:, 2], 0.0)


def test_mirror_and_snap_on_the_builtin_face_put_each_point_on_its_surface(wv_face):
    point, normal = wv_face.symmetry_plane()
    for m in wv_face.muscles:
        twin = snapped(mirrored(m, point, normal), {"skin": wv_face.skin,
                                                    "skull": wv_face.skull}, like=m, tol=0.05)
        for param, where in m.point_surfaces().items():
            surface = wv_face.skin if where == "skin" else wv_face.skull
            old = np.asarray(getattr(m, param), float).reshape(-1, 3)
            new = np.asarray(getattr(twin, param), float).reshape(-1, 3)
            was_on = np.linalg.norm(closest_points(surface, old) - old, axis=1) <= 0.05
            gap = np.linalg.norm(closest_points(surface, new) - new, axis=1)
            assert (gap[was_on] < 1e-9).all(), (m.name, param)
            plain = np.asarray(getattr(mirrored(m, point, normal), param)).reshape(-1, 3)
            if not was_on.any():  # off their surface (the frontalis lines): kept
                assert np.array_equal(new, plain)


# ---------------------------------------------------------------------- the CLI reads it
def test_the_cli_lists_each_type_with_its_declared_parameters(capsys):
    from wrinkle_vis import cli
    from wrinkle_vis.core.params import parameter_table

    assert cli.main(["types", "linear", "ring"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("linear (wrinkle_vis.core.muscles.LinearMuscle)")
    assert "ring (wrinkle_vis_ring.RingMuscle)" in out
    for cls in (wv.LinearMuscle, wv.get_muscle_type("ring")):
        for row in parameter_table(cls):
            assert row[0] in out and row[5] in out
    line = next(x for x in out.splitlines() if x.split()[:1] == ["max_angle_deg"])
    assert line.split()[1:6] == ["Φ", "degrees", "(0,", "90]", "required"]
    line = next(x for x in out.splitlines() if x.split()[:1] == ["fall_start"])
    assert "derived" in line and "(0, inf)" in line
    assert cli.main(["types", "--markdown", "sheet"]) == 0
    md = capsys.readouterr().out
    assert "| length | L_s | face units | (0, inf) | derived | the AOI's length" in md
    assert cli.main(["types", "spiral"]) == 2
    assert "unknown muscle type 'spiral'; installed types:" in capsys.readouterr().err


def test_the_options_are_declared_with_their_metadata_too():
    from wrinkle_vis.app.session import OPTIONS as PANEL_OPTIONS
    from wrinkle_vis.core.muscle import OPTIONS

    specs = Muscle.options()
    assert [p.name for p in specs] == list(OPTIONS)
    for p in specs:
        assert p.unit == "option" and p.choices == OPTIONS[p.name] and p.doc and p.label
    assert specs[0].is_flag and not specs[1].is_flag
    assert specs[1].labelled_choices == {"edges": "edges (Eq. 10)", "gradient": "gradient"}
    assert PANEL_OPTIONS == (("taper", "taper H at the ends", None),
                             ("compression", "eps from", specs[1].labelled_choices))
    assert wv.SheetMuscle.parameter("compression") == specs[1]
    assert "taper" not in [p.name for p in wv.SheetMuscle.parameters()]  # options apart
    with pytest.raises(MuscleParameterError, match="compression = 'fast' is invalid; allowed: "
                                                   "'edges' or 'gradient'"):
        _linear(compression="fast")
    with pytest.raises(MuscleParameterError, match="taper = 'yes' is invalid; allowed: True "
                                                   "or False"):
        _linear(taper="yes")
    with pytest.raises(ValueError, match="an option \\(and only an option\\) has choices"):
        Parameter(name="x", unit="option")
