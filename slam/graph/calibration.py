"""The gyro's mean bias read from a finished run (graph's offline second pass).

On a route that seldom comes back, the loop closures do not hold the local SLAM's yaw against
a gyro bias the online learning catches only in part. A finished run's optimized yaw is the
best the log says of the heading; the raw gyro's integral drifts from it at the gyro's mean
bias. `gyro_bias_from_yaw` reads that rate, `corrected_imu` takes it out of an IMU window.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from slam.base import ImuWindow
from slam.preprocess import yaw_rate_from_imu

__all__ = ["gyro_integral", "gyro_bias_from_yaw", "corrected_imu"]


def gyro_integral(times: np.ndarray, imus: list[ImuWindow | None]) -> np.ndarray | None:
    """(N,) rad: the gyro's rate integrated from the first scan time to each of `times` (N,),
    imus[k] the window ending at times[k]; None if a window after the first has no gyro."""
    total = np.zeros(len(times))
    for k in range(1, len(times)):
        rate = yaw_rate_from_imu(imus[k], times[k - 1], times[k])
        if rate is None:
            return None
        total[k] = total[k - 1] + rate * (times[k] - times[k - 1])
    return total


def gyro_bias_from_yaw(times: np.ndarray, yaw: np.ndarray, integral: np.ndarray) -> float:
    """rad/s: the least-squares slope over time of the gyro's integral (N,) minus the yaw (N,)
    (unwrapped here), both at times (N,) s."""
    t = np.asarray(times, dtype=np.float64)
    drift = np.asarray(integral, dtype=np.float64) - np.unwrap(np.asarray(yaw, dtype=np.float64))
    if len(t) < 2 or np.ptp(t) <= 0:
        return 0.0
    dt = t - t.mean()
    return float(np.dot(dt, drift - drift.mean()) / np.dot(dt, dt))


def corrected_imu(imu: ImuWindow | None, bias: float, t0: float) -> ImuWindow | None:
    """The window with `bias` (rad/s) taken out of its gyro rates, and out of its integrated yaw
    as accumulated since t0 (s)."""
    if imu is None:
        return None
    return dataclasses.replace(imu, gyro=np.asarray(imu.gyro) - bias,
                               sweep_gyro=np.asarray(imu.sweep_gyro) - bias,
                               yaw=np.asarray(imu.yaw) - bias * (np.asarray(imu.t) - t0))
