"""SSIM against a brute-force evaluation of Wang et al.'s formula at single cells."""
import numpy as np
import pytest

from metrics.ssim import ssim, ssim_map


def brute_ssim_at(a, b, r, c, sigma=1.5, radius=5):
    """The formula of Wang et al. 2004 with an explicit normalised Gaussian window."""
    off = np.arange(-radius, radius + 1)
    w = np.exp(-0.5 * (off[:, None] ** 2 + off[None, :] ** 2) / sigma ** 2)
    w /= w.sum()
    pa = a[r - radius:r + radius + 1, c - radius:c + radius + 1]
    pb = b[r - radius:r + radius + 1, c - radius:c + radius + 1]
    ma, mb = (w * pa).sum(), (w * pb).sum()
    va = (w * (pa - ma) ** 2).sum()
    vb = (w * (pb - mb) ** 2).sum()
    cov = (w * (pa - ma) * (pb - mb)).sum()
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    return (2 * ma * mb + c1) * (2 * cov + c2) / ((ma ** 2 + mb ** 2 + c1) * (va + vb + c2))


def test_matches_brute_force_inside(rng):
    a = rng.uniform(size=(30, 30))
    b = np.clip(a + rng.normal(scale=0.2, size=a.shape), 0, 1)
    m = ssim_map(a, b)
    for r, c in [(10, 10), (15, 20), (20, 7)]:
        assert m[r, c] == pytest.approx(brute_ssim_at(a, b, r, c), rel=1e-3)
    # scipy's Gaussian kernel is the same sampled Gaussian, so the match is close


def test_identical_is_one_and_unknown_is_half():
    a = np.zeros((20, 20))
    a[5, :] = 1.0
    assert ssim(a, a) == pytest.approx(1.0)
    b = a.copy()
    b[5, :] = np.nan
    assert ssim(a, b) < 0.9
    assert np.isnan(ssim(np.full((3, 3), np.nan), np.full((3, 3), np.nan)))
