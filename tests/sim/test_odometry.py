import numpy as np
import pytest

from sim.odometry import encoder_ticks, integrate_ticks, odometry_drift, wheel_angles_at

R, SEP, TICKS = 0.033, 0.160, 4096


def test_wheel_angles_piecewise_linear():
    step_t = np.array([0.0, 1.0, 2.0])
    speed = np.array([[1.0, 2.0], [0.0, -1.0]])
    a = wheel_angles_at(np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0]), step_t, speed)
    np.testing.assert_allclose(a, [[0, 0], [0.5, 1], [1, 2], [1, 1.5], [1, 1], [1, 1]])


def test_encoder_counts_whole_ticks():
    per_tick = 2 * np.pi / TICKS
    a = np.array([0.0, 0.4 * per_tick, per_tick, 2.6 * per_tick, -0.5 * per_tick])
    np.testing.assert_array_equal(encoder_ticks(a, TICKS), [0, 0, 1, 2, -1])


def test_straight_line_and_circle():
    t = np.arange(0, 10.0001, 1 / 30)
    # straight at 0.2 m/s
    ang = np.stack([t, t], 1) * (0.2 / R)
    pose, twist = integrate_ticks(t, encoder_ticks(ang, TICKS), np.array([1.0, 2.0, np.pi / 2]),
                                  TICKS, R, SEP)
    tick_m = 2 * np.pi * R / TICKS
    assert pose[-1, 0] == pytest.approx(1.0, abs=1e-9)
    assert pose[-1, 1] == pytest.approx(4.0, abs=tick_m)
    assert np.allclose(twist[2:, 0], 0.2, atol=tick_m * 30)
    # turn in place at 0.5 rad/s: wheels at -+ 0.5 * SEP / 2 / R rad/s
    ws = 0.5 * SEP / 2 / R
    ang = np.stack([-ws * t, ws * t], 1)
    pose, twist = integrate_ticks(t, encoder_ticks(ang, TICKS), np.zeros(3), TICKS, R, SEP)
    assert np.hypot(*pose[-1, :2]) < tick_m  # floor() of -+ angles: half a tick apart
    want = np.mod(5.0 + np.pi, 2 * np.pi) - np.pi
    assert pose[-1, 2] == pytest.approx(want, abs=2 * tick_m / SEP)
    assert np.allclose(twist[2:, 1], 0.5, atol=2 * tick_m / SEP * 30)


def test_drift_of_a_perfect_and_a_scaled_odometry():
    t = np.linspace(0, 100, 1001)
    gt = np.stack([0.1 * t, np.zeros_like(t), np.zeros_like(t)], 1)
    d = odometry_drift(t, gt.copy(), t, gt)
    assert d["distance"] == pytest.approx(10.0) and d["end_error"] == 0 and d["segment_drift"] == 0
    odo = gt.copy()
    odo[:, 0] *= 1.02                     # 2 % scale error
    d = odometry_drift(t, odo, t, gt, segment=2.0)
    assert d["segment_drift"] == pytest.approx(0.02, rel=1e-6)
    assert d["end_error_ratio"] == pytest.approx(0.02, rel=1e-6)
