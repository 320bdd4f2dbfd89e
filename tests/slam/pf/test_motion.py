"""slam.pf.motion: Gmapping's motion model, weight normalisation, Neff, low-variance resampling."""
import numpy as np
import pytest

from slam.pf.motion import (effective_sample_size, motion_std, normalized_weights,
                            sample_motion, systematic_resample)
from slam.pose import compose


def test_neff_uniform_is_n_and_one_hot_is_one():
    assert effective_sample_size(np.full(30, 1 / 30)) == pytest.approx(30)
    w = np.zeros(30)
    w[7] = 1.0
    assert effective_sample_size(w) == pytest.approx(1.0)
    # two equal particles, the rest zero: 2; unnormalised input is normalised
    w = np.zeros(10)
    w[[2, 5]] = 3.0
    assert effective_sample_size(w) == pytest.approx(2.0)


def test_systematic_resampling_counts(rng):
    # weights that are exact multiples of 1/N: particle i gets exactly N * w_i copies
    w = np.array([0.5, 0.25, 0.125, 0.125, 0.0, 0.0, 0.0, 0.0])
    for _ in range(20):
        idx = systematic_resample(w, rng)
        assert np.bincount(idx, minlength=8).tolist() == [4, 2, 1, 1, 0, 0, 0, 0]
        assert np.all(np.diff(idx) >= 0)
    # halves: the last two share one copy, decided by the single random offset
    seen = set()
    for _ in range(50):
        counts = np.bincount(systematic_resample(np.array([0.5, 0.25, 0.125, 0.125]), rng), minlength=4)
        assert counts.tolist() in ([2, 1, 1, 0], [2, 1, 0, 1])
        seen.add(tuple(counts))
    assert len(seen) == 2


def test_systematic_resampling_floor_ceil(rng):
    n = 30
    w = rng.random(n) ** 3
    w /= w.sum()
    for _ in range(50):
        counts = np.bincount(systematic_resample(w, rng), minlength=n)
        assert counts.sum() == n
        assert np.all(counts >= np.floor(n * w) - 1e-9) and np.all(counts <= np.ceil(n * w) + 1e-9)


def test_one_hot_resampling_copies_the_one(rng):
    w = np.zeros(12)
    w[4] = 1.0
    assert np.all(systematic_resample(w, rng) == 4)


def test_uniform_resampling_keeps_everyone(rng):
    assert systematic_resample(np.full(25, 0.04), rng).tolist() == list(range(25))


def test_normalized_weights_ogain_smooths():
    log_w = np.array([0.0, -90.0, -180.0])
    plain = normalized_weights(log_w, ogain=1 / 3)  # gain 1: the plain posterior
    assert plain[0] == pytest.approx(1.0)
    smooth = normalized_weights(log_w, ogain=30.0)  # gain 1/90: exp(0), exp(-1), exp(-2)
    np.testing.assert_allclose(smooth, np.exp([0, -1, -2]) / np.exp([0, -1, -2]).sum())


def test_motion_std_gmapping_formula():
    std = motion_std(np.array([1.0, 0.2, 0.5]), srr=0.1, srt=0.2, str_=0.1, stt=0.2)
    np.testing.assert_allclose(std, [0.1 * 1 + 0.1 * 0.5 + 0.03 * 0.2,
                                      0.1 * 0.2 + 0.1 * 0.5 + 0.03 * 1.0,
                                      0.2 * 0.5 + 0.2 * np.hypot(1.0, 0.2)])


def test_sample_motion_statistics(rng):
    start = np.tile([1.0, 2.0, 0.3], (20000, 1))
    delta = np.array([0.5, 0.0, 0.1])
    out = sample_motion(start, delta, 0.1, 0.2, 0.1, 0.2, rng)
    # the mean lands on the odometry prediction, the yaw spread is the formula's
    np.testing.assert_allclose(out.mean(axis=0), compose(start[0], delta), atol=0.005)
    assert out[:, 2].std() == pytest.approx(0.2 * 0.1 + 0.2 * 0.5, rel=0.05)


def test_no_motion_no_noise(rng):
    p = rng.normal(size=(5, 3))
    np.testing.assert_allclose(sample_motion(p, np.zeros(3), 0.1, 0.2, 0.1, 0.2, rng), p, atol=1e-12)
