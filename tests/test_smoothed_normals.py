"""The smoothed normals' solve (issue 33 M12): the same answer as a direct solve, in a
number of iterations that does not grow with the mesh's resolution."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from meshes import grid, sphere
from scipy.sparse.linalg import spsolve

from wrinkle_vis import subdivide
from wrinkle_vis.core.mesh import (
    block_pcg,
    cotangent_laplacian,
    multilevel_preconditioner,
    smoothed_normals,
    two_level_preconditioner,
    unit_rows,
)


def _system(surface, radius):
    stiffness, areas = cotangent_laplacian(surface)
    return (sp.diags(areas) + 0.5 * radius**2 * stiffness).tocsr(), areas


@pytest.mark.parametrize("surface, radius", [(grid(41, 41, 60.0, bump=20.0), 12.0),
                                             (sphere(4, 50.0), 15.0)])
def test_smoothed_normals_match_a_direct_solve(surface, radius):
    n = surface.vertex_normals()
    system, areas = _system(surface, radius)
    exact = unit_rows(np.column_stack([spsolve(system.tocsc(), areas * n[:, c])
                                       for c in range(3)]))
    got = smoothed_normals(surface, n, radius)
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", got, exact), -1, 1)))
    assert angle.max() < 1e-4
    assert np.array_equal(smoothed_normals(surface, n, radius), got)  # deterministic


def _iterations(system, rhs, precondition) -> int:
    calls = [0]

    def counted(r):
        calls[0] += 1
        return precondition(r)

    x = block_pcg(system, rhs, np.zeros_like(rhs), counted, 1e-8)
    np.testing.assert_allclose(system @ x, rhs, atol=1e-7 * np.abs(rhs).max())
    return calls[0]


def test_two_level_iterations_stay_flat_as_the_mesh_is_refined():
    """Jacobi alone needs about twice the iterations at each refinement (r / h doubles);
    the two-level cycle keeps them about the same."""
    counts = {"jacobi": [], "two-level": []}
    base = grid(17, 17, 60.0, bump=20.0)
    for level in (1, 2, 3):
        surface = subdivide(base, level)
        system, areas = _system(surface, 12.0)
        rhs = areas[:, None] * surface.vertex_normals()
        dinv = 1.0 / system.diagonal()
        counts["jacobi"].append(_iterations(system, rhs, lambda r, d=dinv: d[:, None] * r))
        h = np.sqrt(2.0 * surface.triangle_areas().mean())
        counts["two-level"].append(_iterations(
            system, rhs, two_level_preconditioner(system, surface.points, 6.0 * h)))
    jac, two = counts["jacobi"], counts["two-level"]
    assert jac[-1] > 3 * jac[0], counts
    assert two[-1] < 1.5 * two[0] and two[-1] < jac[-1] / 3, counts


def test_multilevel_cycle_is_symmetric_positive_definite_on_several_levels():
    """The V-cycle that recurses (coarsest 10 unknowns: three levels on this grid) is a
    symmetric positive definite operator, as conjugate gradients need."""
    surface = grid(21, 21, 60.0, bump=20.0)
    system, _ = _system(surface, 12.0)
    h = np.sqrt(2.0 * surface.triangle_areas().mean())
    size = system.shape[0]
    matrix = multilevel_preconditioner(system, surface.points, 3.0 * h, coarsest=10)(
        np.eye(size))
    np.testing.assert_allclose(matrix, matrix.T, atol=1e-12 * np.abs(matrix).max())
    assert np.linalg.eigvalsh(0.5 * (matrix + matrix.T)).min() > 0
    two = two_level_preconditioner(system, surface.points, 3.0 * h)(np.eye(size))
    assert np.abs(two - matrix).max() > 1e-3 * np.abs(two).max()  # it did recurse


def test_multilevel_iterations_stay_flat_and_below_the_two_level_cycle():
    counts = {"two-level": [], "multilevel": []}
    base = grid(17, 17, 60.0, bump=20.0)
    for level in (1, 2, 3):
        surface = subdivide(base, level)
        system, areas = _system(surface, 12.0)
        rhs = areas[:, None] * surface.vertex_normals()
        h = np.sqrt(2.0 * surface.triangle_areas().mean())
        counts["two-level"].append(_iterations(
            system, rhs, two_level_preconditioner(system, surface.points, 6.0 * h)))
        counts["multilevel"].append(_iterations(
            system, rhs, multilevel_preconditioner(system, surface.points, 3.0 * h,
                                                   coarsest=100)))
    two, multi = counts["two-level"], counts["multilevel"]
    assert multi[-1] < 1.5 * multi[0], counts
    assert all(m < t for m, t in zip(multi, two, strict=True)), counts


def test_renumbering_is_numpys_symmetric_permutation():
    from wrinkle_vis.core.mesh import _permuted

    surface = sphere(3, 50.0)
    system, _ = _system(surface, 15.0)
    order = np.random.default_rng(0).permutation(system.shape[0])
    got = _permuted(system, order)
    expected = system[order][:, order].tocsr()
    expected.sort_indices()
    assert np.array_equal(got.indptr, expected.indptr)
    assert np.array_equal(got.indices, expected.indices)
    assert np.array_equal(got.data, expected.data)
