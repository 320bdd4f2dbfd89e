"""Gauss-Newton normal equations kernel against its numpy reference."""
import numpy as np
import pytest

from slam._kernels.gauss_newton import gn_normal_equations, gn_normal_equations_ref, solve3


def _unit_normals(rng, n):
    """n random robot-frame unit normals, every fifth row zero (a point without a normal)."""
    a = rng.uniform(-np.pi, np.pi, n)
    nrm = np.c_[np.cos(a), np.sin(a)]
    nrm[::5] = 0.0
    return nrm


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("with_normals", [False, True])
def test_kernel_matches_reference(seed, with_normals):
    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(20, 60, 2)
    meta = np.array([-1.0, -0.5, 0.1, rows, cols])
    prob = rng.random((rows, cols))
    pts = rng.uniform(-1.5, 1.5, (200, 2))
    pose = np.array([rng.uniform(0.5, 1.5), rng.uniform(0.5, 1.5), rng.uniform(-np.pi, np.pi)])
    if with_normals:
        nrm = _unit_normals(rng, len(pts))
        H, g, cost = gn_normal_equations(prob, meta, pts, pose, nrm)
        Hr, gr, cr = gn_normal_equations_ref(prob, meta, pts, pose, nrm)
        # normals change the Jacobian, not the residuals
        H_full, _, cost_full = gn_normal_equations(prob, meta, pts, pose)
        assert cost == pytest.approx(cost_full) and not np.allclose(H, H_full)
    else:
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
@pytest.mark.parametrize("with_normals", [False, True])
def test_iterate_matches_reference(seed, prior_w, with_normals):
    from slam._kernels.gauss_newton import gn_iterate, gn_iterate_ref
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
    if with_normals:
        nrm = _unit_normals(rng, len(pts))
        a, ca = gn_iterate(prob, meta, pts, pose, 4, 0.2, prior, w, nrm)
        b, cb = gn_iterate_ref(prob, meta, pts, pose, 4, 0.2, prior, w, nrm)
    else:
        a, ca = gn_iterate(prob, meta, pts, pose, 4, 0.2, prior, w)
        b, cb = gn_iterate_ref(prob, meta, pts, pose, 4, 0.2, prior, w)
    np.testing.assert_allclose(a, b, atol=1e-9)
    assert ca == pytest.approx(cb)


def test_yaw_prior_holds_the_yaw_on_a_rotation_symmetric_map():
    """A round bump gives the scan no rotation: the yaw stays where the prior pulls it, and
    a strong prior overrides what the map would do to the yaw."""
    from slam._kernels.gauss_newton import gn_iterate
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


def _textured_wall():
    """A wall along x at y = 2.025 m (a row of cell centres) whose profile across it widens
    and narrows along it: off its crest the map has a gradient along the wall."""
    res, rows, cols = 0.05, 80, 100
    yy, xx = np.mgrid[0:rows, 0:cols]
    x, y = (xx + 0.5) * res, (yy + 0.5) * res
    width = 0.08 + 0.04 * np.sin(2 * np.pi * x / 0.7)
    prob = np.exp(-(y - 2.025) ** 2 / (2 * width ** 2))
    meta = np.array([0.0, 0.0, res, rows, cols])
    pts = np.c_[np.linspace(1.0, 3.0, 101), np.full(101, 2.025)]
    return prob, meta, pts, np.tile([0.0, 1.0], (len(pts), 1))


def test_points_read_along_their_normals_do_not_pull_along_the_wall():
    prob, meta, pts, nrm = _textured_wall()
    pose = np.array([0.0, 0.03, 0.0])          # 3 cm off the crest
    H_full, g_full, _ = gn_normal_equations(prob, meta, pts, pose)
    H, g, _ = gn_normal_equations(prob, meta, pts, pose, nrm)
    assert abs(g_full[0]) > 1e-2 and H_full[0, 0] > 0     # the texture pulls along the wall
    assert g[0] == 0.0 and H[0, 0] == 0.0                # read along the normals it does not
    assert g[1] == pytest.approx(g_full[1])              # across the wall nothing changes


def test_a_straight_wall_read_along_its_normals_steps_where_a_prior_pins_the_rest():
    """One straight wall, read along its normals, constrains y only: with a prior on x the
    steps bring y back onto the wall and leave x at the prior; with no prior at all the
    system is singular and the pose stays where it started."""
    from slam._kernels.gauss_newton import gn_iterate
    prob, meta, pts, nrm = _textured_wall()
    start = np.array([0.0, 0.03, 0.0])
    prior = np.zeros(3)
    pinned, _ = gn_iterate(prob, meta, pts, start, 10, 0.2, prior, np.diag([300.0, 300.0, 1e6]), nrm)
    assert pinned[0] == 0.0 and abs(pinned[1]) < 1e-3
    free, _ = gn_iterate(prob, meta, pts, start, 10, 0.2, prior, np.zeros((3, 3)), nrm)
    np.testing.assert_array_equal(free, start)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_solve3_equals_lapack(seed):
    """Cramer's rule against np.linalg.solve on well- and badly-scaled systems (graph's damped
    normal equations mix m^-2 and rad^-2 weights of 1e4 and more)."""
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(50, 3)) * np.array([1.0, 3.0, 300.0])
    H = J.T @ J + np.diag([1e4, 1e4, 1e2])
    g = rng.normal(size=3)
    x, ok = solve3(H, g)
    assert ok
    np.testing.assert_allclose(x, np.linalg.solve(H, g), rtol=1e-10, atol=0)


def test_solve3_says_when_the_system_is_singular():
    H = np.array([[1.0, 2.0, 0.0], [2.0, 4.0, 0.0], [0.0, 0.0, 1.0]])
    x, ok = solve3(H, np.ones(3))
    assert not ok and not np.any(x)
