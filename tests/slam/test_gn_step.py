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
@pytest.mark.parametrize("prior_w", [(0.0, 0.0, 0.0), (0.0, 0.0, 50.0), (20.0, 20.0, 5.0),
                                     ((30.0, -10.0, 0.0), (-10.0, 5.0, 0.0), (0.0, 0.0, 2.0))])
def test_iterate_matches_reference(seed, prior_w):
    from slam._kernels.gn_step import gn_iterate, gn_iterate_ref
    rng = np.random.default_rng(seed)
    # a smooth bump map so the steps stay well conditioned
    yy, xx = np.mgrid[0:40, 0:40]
    prob = np.exp(-((xx - 20.0) ** 2 + (yy - 18.0) ** 2) / 60.0)
    meta = np.array([0.0, 0.0, 0.1, 40, 40])
    pts = rng.uniform(-0.5, 0.5, (100, 2))
    pose = np.array([2.0, 1.8, 0.1]) + rng.normal(0, 0.05, 3)
    prior = pose + np.array([0.02, -0.03, 3.1])  # yaw near +-pi: the difference must wrap
    w = np.array(prior_w, dtype=np.float64)
    w = np.diag(w) if w.ndim == 1 else w        # per-coordinate weights or a full information
    a, ca = gn_iterate(prob, meta, pts, pose, 4, 0.2, prior, w)
    b, cb = gn_iterate_ref(prob, meta, pts, pose, 4, 0.2, prior, w)
    np.testing.assert_allclose(a, b, atol=1e-9)
    assert ca == pytest.approx(cb)


def test_yaw_prior_holds_the_yaw_on_a_rotation_symmetric_map():
    """A round bump gives the scan no rotation: the yaw stays where the prior pulls it, and
    a strong prior overrides what the map would do to the yaw."""
    from slam._kernels.gn_step import gn_iterate
    yy, xx = np.mgrid[0:40, 0:40]
    prob = np.exp(-((xx - 19.5) ** 2 + (yy - 19.5) ** 2) / 60.0)
    meta = np.array([0.0, 0.0, 0.1, 40, 40])
    ang = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    pts = 0.3 * np.c_[np.cos(ang), np.sin(ang)] + [0.05, 0.0]   # off-centre ring: yaw moves it
    pose = np.array([2.0, 2.0, 0.0])
    prior = np.array([2.0, 2.0, 0.05])
    free, _ = gn_iterate(prob, meta, pts, pose, 10, 0.2, prior, np.zeros((3, 3)))
    held, cost = gn_iterate(prob, meta, pts, pose, 10, 0.2, prior, np.diag([0.0, 0.0, 1e6]))
    assert held[2] == pytest.approx(0.05, abs=1e-3)
    assert abs(free[2] - 0.05) > 1e-2          # without the prior the map decides
    c_map = gn_normal_equations(prob, meta, pts, held)[2]
    assert cost == pytest.approx(c_map + 1e6 * (0.05 - held[2]) ** 2)
