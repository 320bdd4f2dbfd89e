"""Sparse pose adjustment: recovers a known pose graph; robust to one wrong loop closure."""
import numpy as np
import pytest

from slam.graph.optimize import Constraints, optimize_poses, spa_residuals, _jacobian
from slam.pose import compose, relative


def _ring(n=40, radius=3.0):
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([radius * np.cos(a), radius * np.sin(a), a + np.pi / 2], axis=1)


def _graph(truth, rng, sigma_t=0.02, sigma_r=0.01, loops=((0, -1),), wrong=()):
    n = len(truth)
    i = list(range(n - 1))
    j = list(range(1, n))
    robust = [False] * (n - 1)
    for a, b in loops:
        i.append(a); j.append(b % n); robust.append(True)
    z = relative(truth[i], truth[j])
    z = z + rng.normal(0, 1, z.shape) * [sigma_t, sigma_t, sigma_r]
    for a, b, zz in wrong:
        i.append(a); j.append(b); robust.append(True)
        z = np.vstack([z, zz])
    k = len(i)
    return Constraints(np.array(i), np.array(j), z, np.full(k, 1e2), np.full(k, 1e2),
                       np.array(robust))


@pytest.mark.parametrize("anisotropic", [False, True])
def test_jacobian_matches_finite_differences(rng, anisotropic):
    truth = _ring(6)
    c = _graph(truth, rng, loops=((0, 3), (1, 5)))
    if anisotropic:
        k = len(c.i)
        c = Constraints(c.i, c.j, c.z, c.w_t, c.w_r, c.robust, rng.uniform(-np.pi, np.pi, k),
                        rng.uniform(0, 100, k))
    poses = truth + rng.normal(0, 0.1, truth.shape)
    free_col = np.arange(len(poses))
    J = _jacobian(poses, c, free_col, len(poses)).toarray()
    eps = 1e-6
    num = np.zeros_like(J)
    for k in range(poses.size):
        d = np.zeros(poses.size); d[k] = eps
        p1 = poses + d.reshape(-1, 3); p0 = poses - d.reshape(-1, 3)
        num[:, k] = (spa_residuals(p1, c).ravel() - spa_residuals(p0, c).ravel()) / (2 * eps)
    np.testing.assert_allclose(J, num, atol=1e-5)


def test_isotropic_defaults_give_the_same_residuals_bit_for_bit(rng):
    truth = _ring(8)
    c = _graph(truth, rng, loops=((0, 5),))
    k = len(c.i)
    explicit = Constraints(c.i, c.j, c.z, c.w_t, c.w_r, c.robust, np.zeros(k), c.w_t.copy())
    poses = truth + rng.normal(0, 0.05, truth.shape)
    assert np.array_equal(spa_residuals(poses, c), spa_residuals(poses, explicit))


@pytest.mark.parametrize("axis, expected", [(0.0, [1.0, 0.05]), (np.pi / 2, [1.25, 0.0])])
def test_a_sliding_constraint_pulls_only_across_its_axis(axis, expected):
    # pose 1 is 1 m ahead of pose 0 by one constraint; a second one, weighing nothing along
    # `axis` (from its own x axis), says 1.5 m ahead and 0.1 m to the left
    c = Constraints(np.array([0, 0]), np.array([1, 1]), np.array([[1.0, 0.0, 0.0], [1.5, 0.1, 0.0]]),
                    np.array([1e2, 0.0]), np.array([1e2, 1e2]), np.zeros(2, bool),
                    np.array([0.0, axis]), np.array([1e2, 1e2]))
    out = optimize_poses(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), c, tolerance=1e-12)
    np.testing.assert_allclose(out[1, :2], expected, atol=1e-6)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_recovers_known_pose_graph(seed):
    rng = np.random.default_rng(seed)
    truth = _ring(40)
    c = _graph(truth, rng, sigma_t=0.005, sigma_r=0.002, loops=((0, -1), (5, 30), (10, 25)))
    # Initial guess: dead reckoning with a drift, as a local SLAM would give.
    init = truth.copy()
    for k in range(1, len(truth)):
        step = relative(truth[k - 1], truth[k]) + [0.01, 0.0, 0.01]
        init[k] = compose(init[k - 1], step)
    assert np.max(np.linalg.norm(init[:, :2] - truth[:, :2], axis=1)) > 0.3
    c = Constraints(c.i, c.j, c.z, c.w_t, c.w_r, np.zeros_like(c.robust))
    out = optimize_poses(init, c)
    err = np.linalg.norm(out[:, :2] - truth[:, :2], axis=1)
    assert err.max() < 0.05
    np.testing.assert_allclose(out[0], init[0])   # gauge held


def test_wrong_loop_closure_is_tolerated(rng):
    truth = _ring(40)
    bad = np.array([[1.5, -0.8, 0.6]])            # a wildly wrong closure between 3 and 20
    c = _graph(truth, rng, sigma_t=0.003, sigma_r=0.001, loops=((0, -1), (5, 30), (10, 25)),
               wrong=((3, 20, bad),))
    init = truth + rng.normal(0, 0.02, truth.shape)
    init[0] = truth[0]
    out = optimize_poses(init, c, huber_scale=1.0)
    ate = np.sqrt(np.mean(np.sum((out[:, :2] - truth[:, :2]) ** 2, axis=1)))
    # The converged optimum still feels the capped pull of the closure (~0.1 m on a 3 m ring).
    assert ate < 0.15
    # Without the robust loss the same closure does wreck it: the test can fail.
    c_nonrobust = Constraints(c.i, c.j, c.z, c.w_t, c.w_r, np.zeros_like(c.robust))
    out2 = optimize_poses(init, c_nonrobust)
    ate2 = np.sqrt(np.mean(np.sum((out2[:, :2] - truth[:, :2]) ** 2, axis=1)))
    assert ate2 > 10 * ate


@pytest.mark.parametrize("seed", [0, 1])
def test_sparse_lm_matches_scipy_least_squares(seed):
    from scipy.optimize import least_squares
    rng = np.random.default_rng(seed)
    truth = _ring(30)
    c = _graph(truth, rng, sigma_t=0.005, sigma_r=0.002, loops=((0, -1), (4, 20)))
    c = Constraints(c.i, c.j, c.z, c.w_t, c.w_r, np.zeros(len(c.i), bool))  # no Huber: plain least squares
    init = truth + rng.normal(0, 0.03, truth.shape)
    init[0] = truth[0]
    a = optimize_poses(init, c, tolerance=1e-10)

    def residuals(x):
        p = init.copy()
        p[1:] += x.reshape(-1, 3)
        return spa_residuals(p, c).reshape(-1)

    ref = least_squares(residuals, np.zeros(3 * (len(init) - 1)), xtol=1e-12, ftol=1e-12, gtol=1e-12)
    b = init.copy()
    b[1:] += ref.x.reshape(-1, 3)
    b[:, 2] = np.angle(np.exp(1j * b[:, 2]))
    np.testing.assert_allclose(a, b, atol=1e-6)
