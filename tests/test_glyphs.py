"""A muscle type brings its glyph: the registry along the class hierarchy (issue 16)."""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.core.muscle import Muscle, parameter
from wrinkle_vis.plotting import (
    attachment_points,
    generic_glyph,
    glyph_factory,
    muscle_mesh,
    register_glyph,
)
from wrinkle_vis.plotting.glyphs import _GLYPHS, linear_glyph, sheet_glyph


@dataclass(frozen=True)
class TwoPoints(Muscle):
    """A type with no glyph: a point on the skull and a line on the skin."""

    type_name = "two_points_for_test"
    root: tuple = parameter(kw_only=False, label="root", symbol="r", unit="point",
                            shape=(3,), surface="skull", doc="on the bone")
    tips: tuple = parameter(kw_only=False, label="tips", symbol="t", unit="point",
                            shape=(2, 3), surface="skin", doc="in the skin")


@dataclass(frozen=True)
class OnePoint(Muscle):
    type_name = "one_point_for_test"
    spot: tuple = parameter(kw_only=False, label="spot", symbol="s", unit="point",
                            shape=(3,), surface="skin", doc="centre")
    _: KW_ONLY
    reach: float = parameter(12.0, label="reach", symbol="r", unit="length", lo=0.0,
                             doc="reach")

    wrinkle_length = property(lambda self: self.reach)


def test_builtin_types_declare_their_glyphs_and_subclasses_inherit_them():
    assert glyph_factory(wv.LinearMuscle) is linear_glyph
    assert glyph_factory(wv.SheetMuscle) is sheet_glyph

    @dataclass(frozen=True)
    class Sub(wv.LinearMuscle):
        pass

    assert glyph_factory(Sub) is linear_glyph
    assert glyph_factory(TwoPoints) is generic_glyph

    def mine(muscle):
        return generic_glyph(muscle)

    register_glyph(Sub, mine)
    try:
        assert glyph_factory(Sub) is mine and glyph_factory(wv.LinearMuscle) is linear_glyph
    finally:
        _GLYPHS.pop(Sub)
    with pytest.raises(TypeError, match="is not a Muscle subclass"):
        register_glyph(int, mine)


def test_a_broken_glyph_declaration_names_the_type_and_the_fix():
    @dataclass(frozen=True)
    class Broken(wv.SheetMuscle):
        glyph = "no_such_package.glyphs:thing"

    with pytest.raises(ImportError, match=r"Broken declares glyph = 'no_such_package"):
        glyph_factory(Broken)


def test_the_ring_plugin_brings_its_glyph_a_torus_round_its_axis():
    ring_cls = wv.get_muscle_type("ring")
    ring = ring_cls("o", (1.0, 2.0, 3.0), (0.0, 0.0, 1.0), radius=12.0)
    assert glyph_factory(ring_cls).__module__ == "wrinkle_vis_ring.widget"
    mesh = muscle_mesh(ring, 0.5)
    v = mesh.points - np.array([1.0, 2.0, 3.0])
    radial = np.linalg.norm(v[:, :2], axis=1)
    tube = 12.0 / 12.0
    assert radial.min() > 12.0 - tube - 0.05 and radial.max() < 12.0 + tube + 0.05
    assert np.abs(v[:, 2]).max() < tube + 0.05  # in the ring's plane
    assert np.all(mesh.point_data["activation"] == 0.5)


def test_a_type_without_a_glyph_is_drawn_through_its_declared_points():
    m = TwoPoints("t", (0.0, 0.0, 0.0), ((-10.0, 30.0, 0.0), (10.0, 30.0, 0.0)))
    mesh = muscle_mesh(m, 1.0)
    # a fibre from the skull point through the skin line's ends, a thirtieth of the span thick
    pts = np.array([[0, 0, 0], [-10, 30, 0], [10, 30, 0]], float)
    span = 30.0

    def gap(p):  # distance of p to the polyline
        out = np.inf
        for a, b in zip(pts[:-1], pts[1:], strict=True):
            t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
            out = min(out, np.linalg.norm(a + t * (b - a) - p))
        return out

    gaps = np.array([gap(p) for p in mesh.points])
    assert gaps.max() < span / 30.0 * (1 + 1e-5)
    assert np.median(gaps) == pytest.approx(span / 30.0, rel=1e-5)  # a tube round it
    lo, hi = np.array(mesh.bounds).reshape(3, 2).T
    assert (lo[:2] >= [-11, -1]).all() and (hi[:2] <= [11, 31]).all()
    assert hi[0] - lo[0] > 20.0 and hi[1] - lo[1] > 30.0  # reaches every point


def test_a_one_point_type_gets_a_marker_as_wide_as_its_wrinkling_length():
    mesh = muscle_mesh(OnePoint("p", (5.0, 5.0, 5.0)))
    lo, hi = np.array(mesh.bounds).reshape(3, 2).T
    np.testing.assert_allclose(hi - lo, 12.0, atol=0.01)
    np.testing.assert_allclose(0.5 * (hi + lo), 5.0, atol=1e-9)
    assert mesh.n_points > 0 and mesh.n_cells > 0


def test_attachment_points_are_the_ones_declared_on_the_skull(wv_face):
    pts = attachment_points(wv_face)
    want = [np.asarray(getattr(m, p), float).reshape(-1, 3) for m in wv_face.muscles
            for p, where in m.point_surfaces().items() if where == "skull"]
    np.testing.assert_array_equal(pts, np.concatenate(want))
    corrugator = wv_face.muscle("corrugator_L")
    assert any(np.array_equal(p, corrugator.attachment) for p in pts)
    assert not any(np.array_equal(p, corrugator.insertion) for p in pts)
