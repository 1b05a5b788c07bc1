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
