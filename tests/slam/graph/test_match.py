"""Least-squares scan-to-grid matching (Cartographer's ceres scan matcher) vs its reference."""
import numpy as np
import pytest

from slam.graph._match_kernel import match_lm, match_lm_ref
from slam.pose import transform_points


def _room_grid(res=0.05, n=80):
    """A blurred square room: probabilities 0.1 inside/outside, up to 0.9 on the walls."""
    from scipy.ndimage import gaussian_filter
    p = np.zeros((n, n))
    p[10, 10:70] = p[69, 10:70] = p[10:70, 10] = p[10:70, 69] = 1.0
    p[30:40, 40] = 1.0
    p = gaussian_filter(p, 1.0)
    p = 0.1 + 0.8 * p / p.max()
    return p, np.array([0.0, 0.0, res, n, n])


def _scan(rng):
    # points on the walls of the room above, in the frame of pose (2, 2, 0)
    side = np.linspace(0.55, 3.45, 40)
    pts = np.concatenate([np.stack([side, np.full(40, 0.525)], 1), np.stack([side, np.full(40, 3.475)], 1),
                          np.stack([np.full(40, 0.525), side], 1), np.stack([np.full(40, 3.475), side], 1),
                          np.stack([np.full(10, 2.025), np.linspace(1.52, 1.98, 10)], 1)])
    return pts - [2.0, 2.0]


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_match_lm_matches_reference(seed):
    rng = np.random.default_rng(seed)
    prob, meta = _room_grid()
    pts = _scan(rng)
    start = np.array([2.0, 2.0, 0.0]) + rng.normal(0, [0.04, 0.04, 0.03])
    prior = start.copy()
    w = rng.uniform(0.2, 1.0, len(pts))
    a, ca = match_lm(prob, meta, pts, w, start, prior, 1.0, 0.1, 0.1, 50)
    b, cb = match_lm_ref(prob, meta, pts, w, start, prior, 1.0, 0.1, 0.1)
    np.testing.assert_allclose(a, b, atol=2e-3)
    assert ca == pytest.approx(cb, rel=1e-2, abs=1e-6)


@pytest.mark.kernel
def test_match_lm_recovers_offsets(rng):
    prob, meta = _room_grid()
    pts = _scan(rng)
    truth = np.array([2.0, 2.0, 0.0])
    for _ in range(20):
        start = truth + rng.uniform(-1, 1, 3) * [0.05, 0.05, 0.05]
        pose, _ = match_lm(prob, meta, pts, np.ones(len(pts)), start, start, 1.0, 0.0, 0.0, 30)
        assert np.hypot(*(pose[:2] - truth[:2])) < 0.05 * 0.5
        assert abs(pose[2]) < np.radians(1.0)
