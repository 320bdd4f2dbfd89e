"""The odometry pf moves its particles by: the wheels' own, or the wheels' translation turned by
the gyro's heading, as the TurtleBot3's odometry reports it (turtlebot3_node's odometry with
`use_imu: true`, the Burger's setting: the heading change between two updates is the IMU's,
the distance travelled the wheels', laid along the mid-way heading).

The wheels' heading drifts with every millimetre one wheel slips against the other (the
realistic profile: about 26 mrad per square-root metre on the TurtleBot3's 0.16 m base); the
gyro's by its residual bias (the realistic profile: 0.17 mrad per second, 1 sigma).
"""
from __future__ import annotations

import math

import numpy as np

from slam.base import ImuWindow, OdomDelta
from slam.pose import compose, relative, wrap_angle
from slam.preprocess import yaw_rate_from_imu

__all__ = ["ImuHeadingOdometry", "HEADINGS"]

HEADINGS = ("wheels", "imu")


class ImuHeadingOdometry:
    """Wheel odometry re-integrated with the gyro's heading, in the wheel odometry's frame (both
    start at the first wheel pose). A scan without gyro samples keeps the wheels' turn."""

    def __init__(self):
        self._fused: np.ndarray | None = None
        self._wheels: np.ndarray | None = None
        self._t = 0.0

    def update(self, t: float, odom: OdomDelta, imu: ImuWindow | None) -> OdomDelta:
        """The fused odometry at a scan at time t (s), from the wheel odometry and the IMU
        samples since the previous scan: its pose, the previous one and, when the wheels'
        has one, the pose at the scan's last beam (the wheels' motion during the sweep)."""
        wheels = np.asarray(odom.pose, dtype=np.float64)
        if self._fused is None:
            self._fused, self._wheels, self._t = wheels.copy(), wheels.copy(), t
            return OdomDelta(wheels.copy(), wheels.copy(), odom.sweep_end)
        step = relative(self._wheels, wheels)
        rate = yaw_rate_from_imu(imu, self._t, t) if t > self._t else None
        turn = step[2] if rate is None else rate * (t - self._t)
        # the wheels' distance, signed by the direction of travel, along the mid-way heading
        dist = math.copysign(math.hypot(step[0], step[1]), step[0])
        prev = self._fused
        mid = prev[2] + 0.5 * turn
        self._fused = np.array([prev[0] + dist * math.cos(mid), prev[1] + dist * math.sin(mid),
                                wrap_angle(prev[2] + turn)])
        self._wheels, self._t = wheels.copy(), t
        return OdomDelta(self._fused.copy(), prev.copy(), _sweep_end(self._fused, wheels, odom))


def _sweep_end(fused: np.ndarray, wheels: np.ndarray, odom: OdomDelta) -> np.ndarray | None:
    """The wheels' motion from the scan to its last beam, composed onto the fused pose."""
    if odom.sweep_end is None:
        return None
    return compose(fused, relative(wheels, np.asarray(odom.sweep_end, dtype=np.float64)))
