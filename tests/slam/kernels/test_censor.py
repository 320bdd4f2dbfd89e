"""The censoring shortfall kernel against its numpy reference, and what it corrects."""
import numpy as np
import pytest

from slam._kernels.censor import censoring_shortfall, censoring_shortfall_ref

SIGMA, RMAX = 0.0875, 3.5        # the LDS-01 at 3.5 m (2.5 % of the range)


def _revolution(rng, walls, sigma=SIGMA, range_max=RMAX, beams=360):
    """(true distances, ranges) of equal sectors of beams at the given distances (inf: open
    space), Gaussian range noise, the readings beyond range_max lost as a lidar loses them."""
    d = np.repeat(np.asarray(walls, float), beams // len(walls))
    r = d + rng.normal(0.0, sigma, d.shape)
    r[~(r < range_max)] = np.inf
    return d, r


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("circular", [True, False])
def test_kernel_matches_reference(seed, circular):
    rng = np.random.default_rng(seed)
    walls = rng.choice([1.0, 2.8, 3.2, 3.35, 3.45, 3.5, 3.6, np.inf], size=int(rng.integers(3, 12)))
    _, r = _revolution(rng, walls, beams=int(rng.integers(20, 40)) * len(walls))
    r[rng.random(len(r)) < 0.05] = np.nan
    half = int(rng.integers(1, 6))
    a = censoring_shortfall(r, RMAX, SIGMA, half, circular)
    b = censoring_shortfall_ref(r, RMAX, SIGMA, half, circular)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)
    assert (a > 0).any()


def test_corrected_hits_of_walls_near_the_limit_are_unbiased_and_far_walls_untouched(rng):
    walls = [1.0, np.inf, 2.9, np.inf, 3.3, np.inf, 3.45, 3.5]
    raw = {w: [] for w in walls if np.isfinite(w)}
    fixed = {w: [] for w in raw}
    for _ in range(300):
        d, r = _revolution(rng, walls)
        short = censoring_shortfall(r, RMAX, SIGMA, 4, True)
        assert np.all(short[~np.isfinite(r)] == 0) and np.all(short >= 0)
        assert np.all(short[d == 1.0] == 0)                  # 29 sigma inside the limit
        for w in raw:
            sel = (d == w) & np.isfinite(r)
            raw[w].append(r[sel])
            fixed[w].append(r[sel] + short[sel])
    for w in raw:
        kept, corrected = np.concatenate(raw[w]), np.concatenate(fixed[w])
        se = SIGMA / np.sqrt(len(kept))
        if w >= 3.45:                                        # within a sigma of the limit
            assert kept.mean() < w - 0.3 * SIGMA             # what is kept comes back short
        # within an eighth of a sigma of the truth: the neighbours' mean (8 beams) estimates
        # the wall's distance with noise, which the convex inversion turns into a bias of its own
        assert abs(corrected.mean() - w) < 0.125 * SIGMA + 3 * se, (w, kept.mean(), corrected.mean())
        if w < 3.0:
            assert np.abs(corrected - kept).max() < 1e-5 * SIGMA    # under a micrometre


def test_a_lone_hit_is_corrected_by_its_own_range():
    r = np.full(40, np.inf)
    r[10] = 3.45
    short = censoring_shortfall(r, RMAX, SIGMA, 4, True)
    assert short[10] > 0.5 * SIGMA and np.count_nonzero(short) == 1
    np.testing.assert_allclose(short, censoring_shortfall_ref(r, RMAX, SIGMA, 4, True))


def test_a_sensor_without_noise_loses_nothing():
    r = np.array([3.49, 3.499, np.inf, 1.0])
    for sigma in (0.0, -1.0):
        assert not censoring_shortfall(r, RMAX, sigma, 4, True).any()
        assert not censoring_shortfall_ref(r, RMAX, sigma, 4, True).any()
