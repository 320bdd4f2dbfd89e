import numpy as np
import pytest

from sim.imu import channel_noise, simulate_imu, true_imu
from sim.noise import ImuAxisNoise, load_profile


def _circle(dt=0.005, T=20.0, v=0.2, w=0.5):
    t = np.arange(0, T, dt)
    yaw = w * t
    x, y = v / w * np.sin(yaw), v / w * (1 - np.cos(yaw))
    return t, np.stack([x, y, yaw], 1)


def test_true_imu_on_a_circle():
    _, gt = _circle()
    rate, acc = true_imu(gt, 0.005)
    inner = slice(2, -2)
    assert np.allclose(rate[inner], 0.5)
    # centripetal v*w to the left, nothing forward
    np.testing.assert_allclose(acc[inner, 0], 0.0, atol=1e-5)
    np.testing.assert_allclose(acc[inner, 1], 0.1, atol=1e-5)


def test_ideal_imu_integrates_to_the_true_yaw():
    _, gt = _circle()
    idx, gyro, accel, yaw = simulate_imu(gt, 0.005, 2, load_profile("ideal").imu, 0.0,
                                         np.random.default_rng(0))
    assert np.array_equal(idx, np.arange(0, len(gt), 2))
    want = np.mod(gt[idx, 2] + np.pi, 2 * np.pi) - np.pi
    np.testing.assert_allclose(np.mod(yaw - want + np.pi, 2 * np.pi) - np.pi, 0, atol=1e-6)


def test_white_noise_sigma_from_density():
    n = ImuAxisNoise(density=1.745e-4)
    e = channel_noise(200000, 0.01, n, np.random.default_rng(1))
    assert np.std(e) == pytest.approx(1.745e-4 * 10, rel=0.02)
    assert abs(np.mean(e)) < 1e-5


def test_bias_and_random_walk():
    n = ImuAxisNoise(bias_mean=0.1, bias_stddev=0.001)
    biases = [channel_noise(3, 0.01, n, np.random.default_rng(s))[0] for s in range(200)]
    assert np.allclose(np.abs(biases), 0.1, atol=0.005)
    assert 40 < sum(b > 0 for b in biases) < 160       # random sign, as Gazebo draws it
    walk = ImuAxisNoise(bias_walk=1e-3)
    ends = [channel_noise(10000, 0.01, walk, np.random.default_rng(s))[-1] for s in range(300)]
    # after 100 s: sigma = 1e-3 * sqrt(100)
    assert np.std(ends) == pytest.approx(1e-2, rel=0.15)


def test_realistic_gyro_bias_makes_the_yaw_drift():
    _, gt = _circle(T=300.0)
    _, _, _, yaw = simulate_imu(gt, 0.005, 2, load_profile("realistic").imu, 0.0,
                                np.random.default_rng(3))
    err = np.mod(yaw[-1] - gt[-2, 2] + np.pi, 2 * np.pi) - np.pi
    assert 1e-4 < abs(err) < 0.5
