"""graph's offline gyro calibration (slam/graph/calibration.py): the gyro's integral, the bias
read from a yaw, the corrected IMU windows; and the second run it drives."""
import dataclasses

import numpy as np
import pytest

from slam.base import ImuWindow
from slam.graph.calibration import corrected_imu, gyro_bias_from_yaw, gyro_integral
from slam.preprocess import yaw_rate_from_imu


def _windows(times, rate_of_t, hz=100.0):
    """IMU windows (previous scan time, scan time] sampled at hz from rate_of_t."""
    out = [None]
    for t0, t1 in zip(times[:-1], times[1:]):
        ts = np.arange(np.ceil(t0 * hz) / hz, t1 + 1e-9, 1.0 / hz)
        ts = ts[ts > t0]
        out.append(ImuWindow(t=ts, gyro=rate_of_t(ts), accel=np.zeros((len(ts), 2)),
                             yaw=np.cumsum(rate_of_t(ts)) / hz, sweep_gyro=rate_of_t(ts[:3])))
    return out


def test_gyro_integral_follows_a_constant_and_a_changing_rate():
    times = np.arange(0.0, 20.0, 0.2)
    const = gyro_integral(times, _windows(times, lambda t: np.full(len(t), 0.3)))
    assert np.allclose(const, 0.3 * times, atol=1e-9)
    ramp = gyro_integral(times, _windows(times, lambda t: 0.01 * t))
    # held rates: within one sample step of the exact 0.005 t^2
    assert np.allclose(ramp, 0.005 * times ** 2, atol=0.01 * 0.01 * times.max() + 1e-9)


def test_gyro_integral_is_none_when_a_window_has_no_gyro():
    times = np.arange(0.0, 2.0, 0.2)
    imus = _windows(times, lambda t: np.zeros(len(t)))
    imus[4] = dataclasses.replace(imus[4], t=np.zeros(0), gyro=np.zeros(0))
    assert gyro_integral(times, imus) is None


@pytest.mark.parametrize("bias", [-3e-4, 0.0, 1.7e-4, 0.01])
def test_bias_is_the_slope_of_the_integral_minus_the_yaw(bias):
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0.0, 400.0, 2000))
    turning = 0.4 * np.sin(0.05 * t) + 2.0 * t / 400.0     # several turns: the yaw wraps
    integral = turning + bias * t
    yaw = np.angle(np.exp(1j * (turning + rng.normal(0.0, 0.002, len(t)))))
    assert gyro_bias_from_yaw(t, yaw, integral) == pytest.approx(bias, abs=2e-6)


def test_corrected_imu_takes_the_bias_out_of_rates_and_integrated_yaw():
    times = np.array([0.0, 0.2, 0.4])
    imu = _windows(times, lambda t: np.full(len(t), 0.1))[2]
    out = corrected_imu(imu, 0.02, t0=0.0)
    assert np.allclose(out.gyro, 0.08) and np.allclose(out.sweep_gyro, 0.08)
    assert np.allclose(out.yaw, imu.yaw - 0.02 * imu.t)
    assert yaw_rate_from_imu(out, 0.2, 0.4) == pytest.approx(0.08)
    assert corrected_imu(None, 0.02, 0.0) is None


def test_the_shipped_config_turns_calibration_on_and_the_defaults_do_not():
    from pathlib import Path
    from slam.registry import load_config
    path = Path(__file__).parents[3] / "slam" / "configs" / "graph_gyro_calibrated.yaml"
    assert load_config("graph", path).calibrate_gyro
    assert not load_config("graph").calibrate_gyro
    with pytest.raises(Exception, match="calibrated_rotation_weight"):
        load_config("graph", {"calibrated_rotation_weight": -1.0})
