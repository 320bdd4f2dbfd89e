"""Gauss-Newton normal equations kernel against its numpy reference."""
import numpy as np
import pytest

from slam._kernels.gn_step import gn_normal_equations, gn_normal_equations_ref


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(6))
def test_kernel_matches_reference(seed):
    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(20, 60, 2)
    meta = np.array([-1.0, -0.5, 0.1, rows, cols])
    prob = rng.random((rows, cols))
    pts = rng.uniform(-1.5, 1.5, (200, 2))
    pose = np.array([rng.uniform(0.5, 1.5), rng.uniform(0.5, 1.5), rng.uniform(-np.pi, np.pi)])
    H, g, cost = gn_normal_equations(prob, meta, pts, pose)
    Hr, gr, cr = gn_normal_equations_ref(prob, meta, pts, pose)
    np.testing.assert_allclose(H, Hr, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(g, gr, rtol=1e-10, atol=1e-9)
    assert cost == pytest.approx(cr)


def test_gradient_of_cost_matches_finite_differences(rng):
    """g = J^T r is minus half the gradient of the cost sum r^2."""
    prob = rng.random((30, 30))
    meta = np.array([0.0, 0.0, 0.1, 30, 30])
    pts = rng.uniform(-0.8, 0.8, (50, 2))
    pose = np.array([1.5, 1.4, 0.3])
    _, g, _ = gn_normal_equations(prob, meta, pts, pose)
    h = 1e-6
    for k in range(3):
        d = np.zeros(3)
        d[k] = h
        cp = gn_normal_equations(prob, meta, pts, pose + d)[2]
        cm = gn_normal_equations(prob, meta, pts, pose - d)[2]
        assert -(cp - cm) / (2 * h) / 2 == pytest.approx(g[k], rel=1e-4, abs=1e-6)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_iterate_matches_reference(seed):
    from slam._kernels.gn_step import gn_iterate, gn_iterate_ref
    rng = np.random.default_rng(seed)
    # a smooth bump map so the steps stay well conditioned
    yy, xx = np.mgrid[0:40, 0:40]
    prob = np.exp(-((xx - 20.0) ** 2 + (yy - 18.0) ** 2) / 60.0)
    meta = np.array([0.0, 0.0, 0.1, 40, 40])
    pts = rng.uniform(-0.5, 0.5, (100, 2))
    pose = np.array([2.0, 1.8, 0.1]) + rng.normal(0, 0.05, 3)
    a, ca = gn_iterate(prob, meta, pts, pose, 4, 0.2)
    b, cb = gn_iterate_ref(prob, meta, pts, pose, 4, 0.2)
    np.testing.assert_allclose(a, b, atol=1e-9)
    assert ca == pytest.approx(cb)
