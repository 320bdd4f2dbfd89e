"""slam.pf.odometry: the wheels' distance turned by the gyro's heading (the TurtleBot3's odometry)."""
import math

import numpy as np
import pytest

from slam.base import ImuWindow, OdomDelta
from slam.pf.odometry import ImuHeadingOdometry
from slam.pose import compose, relative

RATE = 100.0   # Hz, the gyro


def _route(steps):
    """Scan times (s) and true poses from (duration s, speed m/s, turn rate rad/s) legs, a
    scan every 0.2 s."""
    t, poses = [0.0], [np.zeros(3)]
    for duration, v, w in steps:
        for _ in range(round(duration / 0.2)):
            dt = 0.2
            p = poses[-1]
            mid = p[2] + 0.5 * w * dt
            poses.append(np.array([p[0] + v * dt * math.cos(mid), p[1] + v * dt * math.sin(mid),
                                   p[2] + w * dt]))
            t.append(t[-1] + dt)
    return np.array(t), np.array(poses)


def _wheels(poses, turn_scale):
    """Wheel odometry whose every turn is turn_scale x the true one (a wheel base error)."""
    out = [poses[0]]
    for a, b in zip(poses[:-1], poses[1:]):
        step = relative(a, b)
        step[2] *= turn_scale
        out.append(compose(out[-1], step))
    return np.array(out)


def _window(t0, t1, rate):
    ts = np.arange(math.floor(t0 * RATE) + 1, math.floor(t1 * RATE + 1e-9) + 1) / RATE
    return ImuWindow(t=ts, gyro=np.full(len(ts), rate), accel=np.zeros((len(ts), 2)),
                     yaw=np.zeros(len(ts)))


def _fuse(t, wheels, rates, with_gyro=True):
    odo = ImuHeadingOdometry()
    out = []
    for k in range(len(t)):
        prev = wheels[max(k - 1, 0)]
        imu = _window(t[k - 1], t[k], rates[k - 1]) if k and with_gyro else None
        out.append(odo.update(t[k], OdomDelta(wheels[k], prev), imu).pose)
    return np.array(out)


LEGS = [(2.0, 0.2, 0.0), (2.0, 0.0, math.pi / 4), (2.0, 0.2, 0.0), (1.0, 0.1, 0.3)]


def test_the_gyros_heading_replaces_the_wheels_turn():
    t, truth = _route(LEGS)
    rates = np.concatenate([[w] * round(d / 0.2) for d, _, w in LEGS])
    wheels = _wheels(truth, 1.05)
    fused = _fuse(t, wheels, rates)
    # the wheels' 5 % too large turn moves the last leg by centimetres; the gyro's keeps it
    assert np.max(np.hypot(*(wheels[:, :2] - truth[:, :2]).T)) > 0.02
    np.testing.assert_allclose(fused, truth, atol=1e-9)


def test_the_first_scan_and_a_scan_without_gyro_samples_keep_the_wheels():
    t, truth = _route(LEGS)
    rates = np.concatenate([[w] * round(d / 0.2) for d, _, w in LEGS])
    # consistent wheels (their chords point at half their turn) come back as they are ...
    np.testing.assert_allclose(_fuse(t, truth, rates, with_gyro=False), truth, atol=1e-9)
    # ... and wrong ones keep their heading
    wheels = _wheels(truth, 1.05)
    np.testing.assert_allclose(_fuse(t, wheels, rates, with_gyro=False)[:, 2], wheels[:, 2],
                               atol=1e-9)
    first = ImuHeadingOdometry().update(0.0, OdomDelta(wheels[3], wheels[2], wheels[4]), None)
    np.testing.assert_array_equal(first.pose, wheels[3])
    np.testing.assert_array_equal(first.sweep_end, wheels[4])


def test_the_sweep_end_carries_the_wheels_motion_onto_the_fused_pose():
    odo = ImuHeadingOdometry()
    odo.update(0.0, OdomDelta(np.zeros(3), np.zeros(3)), None)
    wheel = np.array([0.04, 0.0, 0.1])
    end = compose(wheel, np.array([0.01, 0.0, 0.02]))
    fused = odo.update(0.2, OdomDelta(wheel, np.zeros(3), end), _window(0.0, 0.2, 0.25))
    assert fused.pose[2] == pytest.approx(0.05)                 # the gyro's 0.25 rad/s for 0.2 s
    np.testing.assert_allclose(relative(fused.pose, fused.sweep_end), [0.01, 0.0, 0.02], atol=1e-12)
    np.testing.assert_allclose(fused.prev_pose, np.zeros(3))
