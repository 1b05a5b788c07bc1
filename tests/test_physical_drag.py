"""A muscle layout change on the physical skin (core/skin.py SpringRest, _GlobalSolve): the
rest data shared, no factorization per layout, warm starts, and the same physics."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import wrinkle_vis as wv
from wrinkle_vis.core import skin as skin_module
from wrinkle_vis.core.editing import with_point
from wrinkle_vis.core.skin import SkinMaterial, SpringSkin

MUSCLE = "frontalis_outer_L"


@pytest.fixture(scope="module")
def paper_face():
    return wv.datasets.load_face().with_skin_model("physical")


def _moved(face, offset):
    """``face`` with the first insertion point of :data:`MUSCLE` moved by ``offset`` mm."""
    m = face.muscle(MUSCLE)
    point = np.asarray(m.insertion_line[0], dtype=float) + offset
    return face.with_muscle(with_point(m, "insertion_line", 0, point))


def _fresh(face):
    """The same layout as a face of its own (no cache shared with any other face)."""
    return wv.FaceModel(face.skin, face.skull, face.muscles, face.expressions, name=face.name,
                        unit=face.unit, skin_model="physical", material=face.material)


def _exact(face, acts):
    """The still frame of ``face`` solved far past the default tolerance."""
    springs = _fresh(face).physical_skin()
    return springs.equilibrium(face.muscle_displacement(acts), tol=1e-11, max_iter=3000)


# the drag below changes the grip on a few vertices (so the low-rank path is exercised)
DRAG = np.array([6.0, 0.0, 0.0])


def test_the_rest_data_is_shared_with_the_with_muscle_copies(paper_face):
    face = paper_face.with_muscle(paper_face.muscle(MUSCLE))  # a derived face, same layout
    dragged = _moved(face, DRAG)
    a, b = face.physical_skin(), dragged.physical_skin()
    assert a is not b  # a layout of its own ...
    assert b.laplacian is a.laplacian and b.J is a.J and b.mass is a.mass  # ... on one rest
    assert b.skull is a.skull and b.skull is dragged._skull_contact()
    assert not np.array_equal(a.k_zone, b.k_zone)  # the grip is the layout's


def test_a_layout_change_factorizes_no_matrix(paper_face, monkeypatch):
    face = _fresh(paper_face)  # a base layout of its own
    face.evaluate("surprise")
    calls = []
    splu = spla.splu
    monkeypatch.setattr(skin_module.spla, "splu", lambda *a, **k: calls.append(1) or splu(*a, **k))
    dragged = _moved(face, DRAG)
    changed = np.count_nonzero(dragged.muscle_grip() != face.muscle_grip())
    assert 0 < changed < 20  # the grip did change, on a few vertices
    dragged.evaluate("surprise")
    for dt in (1.0 / 30.0, 1.0 / 60.0):
        dragged.physical_skin().step(dragged.skin.points, np.zeros_like(dragged.skin.points),
                                     np.zeros_like(dragged.skin.points), dt)
    assert calls == [1, 1]  # the two time steps' matrices are new; the still frame's is not
    calls.clear()
    _moved(dragged, DRAG).evaluate("surprise")
    _moved(dragged, DRAG).physical_skin().step(dragged.skin.points,
                                               np.zeros_like(dragged.skin.points),
                                               np.zeros_like(dragged.skin.points), 1.0 / 30.0)
    assert calls == []


def test_a_dragged_layouts_still_frame_is_that_layouts_equilibrium(paper_face):
    face = paper_face.with_muscle(paper_face.muscle(MUSCLE))
    face.evaluate("surprise")  # the frame the dragged layout starts from
    dragged = _moved(face, DRAG)
    acts = dragged.activations_for("surprise")
    x = dragged.evaluate("surprise", fold_guard=False, warm_start=True).deformed_points
    scratch = _fresh(dragged).evaluate("surprise", fold_guard=False).deformed_points
    exact = _exact(dragged, acts)
    size = dragged.physical_skin().size()
    # the default tolerance (1e-7 of the size, on the iteration's step) leaves ~1.5e-5 of
    # the size from the exact minimum, from any start
    err_scratch = np.abs(scratch - exact).max() / size
    err_dragged = np.abs(x - exact).max() / size
    assert err_scratch < 3e-5 and err_dragged < 3e-5
    assert np.abs(x - scratch).max() / size < 5e-5
    assert not np.allclose(x, face.evaluate("surprise", fold_guard=False).deformed_points,
                           atol=1e-3)  # the drag did move the skin


def test_the_low_rank_solve_is_the_layouts_own_solve(paper_face):
    face = _fresh(paper_face)  # a base layout of its own
    dragged = _moved(face, DRAG)
    springs = dragged.physical_skin()
    base = face.physical_skin()
    for h in (None, 1.0 / 30.0):
        base._factor(h)  # the base layout factorized first
        solve = springs._factor(h)
        assert 0 < len(solve.ids) < 20
        diag = springs.shared.diagonal(springs.anchor, h)
        own = spla.splu((springs.laplacian + sp.diags(diag)).tocsc())
        b = np.asfortranarray(np.random.default_rng(1).normal(size=(springs.n, 3)))
        want = own.solve(b)
        assert np.abs(solve.solve(b) - want).max() <= 1e-10 * np.abs(want).max()


def test_a_time_step_on_a_dragged_layout_equals_a_fresh_faces(paper_face):
    face = _fresh(paper_face)  # a base layout of its own
    face.physical_skin()._factor(1.0 / 30.0)
    dragged = _moved(face, DRAG)
    fresh = _fresh(dragged)
    states = []
    for f in (dragged, fresh):
        sim = f.simulator("surprise")
        for _ in range(6):
            sim.advance()
        states.append(sim.x)
    assert len(dragged.physical_skin()._factor(1.0 / 30.0).ids) > 0
    moved = np.abs(states[1] - dragged.skin.points).max()
    assert np.abs(states[0] - states[1]).max() <= 1e-9 * moved


def test_a_dragged_layout_starts_from_the_previous_frame(paper_face, monkeypatch):
    face = paper_face.with_muscle(paper_face.muscle(MUSCLE))
    face.evaluate("surprise")
    solves = []  # per solve: the first step's size and the number of iterations
    anderson = skin_module._anderson

    def recorded(g, x, *args):
        steps = []

        def step(y):
            out = g(y)
            steps.append(np.abs(out - y).max())
            return out
        out = anderson(step, x, *args)
        solves.append((steps[0], len(steps)))
        return out

    monkeypatch.setattr(skin_module, "_anderson", recorded)
    dragged = _moved(face, np.array([0.5, 0.0, 0.0]))  # a mouse move
    dragged.evaluate("surprise", warm_start=True)
    _fresh(dragged).evaluate("surprise")  # cold: from the rest skin
    (warm_step, warm_iterations), (cold_step, cold_iterations) = solves
    assert warm_step < 0.1 * cold_step
    assert warm_iterations < 0.7 * cold_iterations


def test_a_still_frame_does_not_depend_on_its_start(paper_face):
    face = _moved(paper_face, DRAG)
    acts = face.activations_for("fear")
    springs = face.physical_skin()
    pull = face.muscle_displacement(acts)
    exact = _exact(face, acts)
    size = springs.size()
    rng = np.random.default_rng(7)
    starts = [None, face.skin.points + rng.normal(scale=0.5, size=face.skin.points.shape),
              face.evaluate("surprise", fold_guard=False).deformed_points]
    for x0 in starts:
        x = springs.equilibrium(pull, x0)
        assert np.abs(x - exact).max() / size < 3e-5


def test_the_same_face_gives_the_same_frame_bit_for_bit(paper_face):
    face = paper_face.with_muscle(paper_face.muscle(MUSCLE))
    first = face.evaluate("surprise").deformed_points
    _moved(face, DRAG).evaluate("surprise")  # another layout's frame, kept for warm starts
    again = face.evaluate("surprise").deformed_points
    assert np.array_equal(first, again)


def test_a_cold_frame_does_not_depend_on_the_frames_asked_for_before(paper_face):
    """Without ``warm_start`` a still frame starts from the rest skin: a face whose family
    solved the same activations before (warm, on a dragged layout) gives the frame a fresh
    face gives, bit for bit (an export, a sweep run, a test), and a warm answer kept by a
    skin is not handed to a cold request."""
    face = _fresh(paper_face)
    face.evaluate("fear", fold_guard=False)  # its layout factorized: the family's base
    dragged = _moved(face, DRAG)
    dragged.evaluate("surprise", fold_guard=False)
    warm = dragged.evaluate("surprise", fold_guard=False, warm_start=True).deformed_points
    cold = face.evaluate("surprise", fold_guard=False).deformed_points
    assert np.array_equal(cold, _fresh(paper_face).evaluate("surprise",
                                                            fold_guard=False).deformed_points)
    face.evaluate("surprise", fold_guard=False, warm_start=True)  # warm: kept by the skin
    assert np.array_equal(face.evaluate("surprise", fold_guard=False).deformed_points, cold)
    assert warm.shape == cold.shape


def test_a_large_layout_change_is_factorized_and_becomes_the_base(paper_face):
    face = _fresh(paper_face)  # a base layout of its own
    shared = face.physical_skin().shared
    face.physical_skin()._factor(None)
    count = shared.factorizations
    far = face.without_muscle("orbicularis_oculi_L").without_muscle("orbicularis_oculi_R")
    changed = np.count_nonzero(far.muscle_grip() != face.muscle_grip())
    assert changed > 100
    springs = far.physical_skin()
    assert springs.shared is shared
    assert len(springs._factor(None).ids) == 0
    assert shared.factorizations == count + 1
    x = far.evaluate("surprise", fold_guard=False).deformed_points
    ref = _fresh(far).evaluate("surprise", fold_guard=False).deformed_points
    assert np.array_equal(x, ref) or np.abs(x - ref).max() / springs.size() < 5e-5


def test_a_spring_skin_checks_its_shared_data_is_of_its_material(paper_face):
    springs = paper_face.physical_skin()
    with pytest.raises(ValueError, match="another material"):
        SpringSkin(paper_face.skin, springs.grip, SkinMaterial(damping=3.0),
                   shared=springs.shared)


def _grid_face():
    """A 11 x 11 plate, a skull 5 mm under it, one linear muscle."""
    from meshes import grid

    skin = grid(11, 11, 60.0)
    skull = wv.TriangleSurface(skin.points - [0.0, 0.0, 5.0], skin.triangles)
    m = wv.LinearMuscle("lin", (-25.0, 0.0, -3.0), (5.0, 0.0, 0.0), radius=40.0,
                        max_angle_deg=40.0, lambda_w=0.3, n_wrinkles=3, k0=1.0, alpha=0.5)
    return wv.FaceModel(skin, skull, [m], expressions={}, skin_model="physical")


def test_a_dragged_layouts_time_steps_keep_the_rest_and_settle_as_its_own():
    face = _grid_face()
    face.simulator(None).advance()  # the base layout's step factorized
    m = face.muscle("lin")
    dragged = face.with_muscle(m.replace(insertion=(5.0, 2.0, 0.0)))  # 6 vertices
    sim = dragged.simulator(None)
    sim.advance()
    assert len(dragged.physical_skin()._factor(1.0 / 30.0).ids) > 0  # the low-rank path
    for _ in range(999):
        sim.advance()
    size = np.linalg.norm(np.ptp(face.skin.points, axis=0))
    assert np.abs(sim.x - face.skin.points).max() <= 1e-9 * size
    assert np.abs(sim.v).max() <= 1e-9 * size
    # a step to full activation settles on the still frame, as on a face of its own
    runs = [f.simulator({"lin": 1.0}) for f in (dragged, _fresh(dragged))]
    for s in runs:
        s.advance_to(1.5)
    assert np.abs(runs[0].x - runs[1].x).max() <= 1e-9 * size
    still = dragged.evaluate({"lin": 1.0}, fold_guard=False).deformed_points
    assert np.abs(runs[0].x - still).max() <= 1e-4 * size
