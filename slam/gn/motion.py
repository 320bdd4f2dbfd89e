"""gn's motion prediction: no wheel odometry, only the gyro and the estimates themselves.

The rotation between scans comes from the gyro (hector: through its imu/tf prior); the
translation prediction stays at the last pose (Hector's), and the estimates' mean velocity
over deskew_velocity_window gives the de-skew twist and the constant-velocity position that
the velocity and degeneracy priors pull towards (not in hector).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slam.base import ImuWindow
from slam.gn.config import GnConfig
from slam.pose import wrap_angle
from slam.preprocess import twist_from_poses, yaw_rate_from_imu

__all__ = ["Prediction", "predict"]


@dataclass(frozen=True, eq=False)
class Prediction:
    """pose: (3,) prior of the match; twist: (3,) for de-skewing (None at the first scan);
    moved_xy: (2,) the position moved on at the estimates' mean velocity."""

    pose: np.ndarray
    twist: np.ndarray | None
    moved_xy: np.ndarray


def _mean_twist(times: list[float], poses: list[np.ndarray], window: float) -> np.ndarray:
    """(3,) mean twist of the estimates over the last `window` s (zeros if there is none).
    A mean over several scans: the last pair alone feeds the matching noise back into the
    de-skew and makes the estimate oscillate."""
    twist = np.zeros(3)
    if window > 0 and len(poses) > 1:
        k = len(times) - 1
        j = k
        while j > 0 and times[k] - times[j - 1] <= window + 1e-9:
            j -= 1
        if j < k:
            twist = twist_from_poses(poses[j], poses[k], times[k] - times[j])
    return twist


def predict(cfg: GnConfig, pose: np.ndarray, times: list[float], poses: list[np.ndarray],
            t: float, imu: ImuWindow | None) -> Prediction:
    """The prediction for a scan at time t from the last pose (3,) and the estimates so far."""
    pred = np.asarray(pose, dtype=np.float64).copy()
    if not poses:
        return Prediction(pred, None, pred[:2].copy())
    dt = t - times[-1]
    twist = _mean_twist(times, poses, cfg.deskew_velocity_window)
    w = yaw_rate_from_imu(imu, times[-1], t) if cfg.use_imu else None
    # the body-frame velocity carried along the arc: the chord points at the mid-way yaw
    yaw_mid = pred[2] + 0.5 * (twist[2] if w is None else w) * dt
    c, s = math.cos(yaw_mid), math.sin(yaw_mid)
    moved_xy = pred[:2] + np.array([c * twist[0] - s * twist[1], s * twist[0] + c * twist[1]]) * dt
    if w is not None:
        pred[2] = wrap_angle(pred[2] + w * dt)
        twist[2] = w
    return Prediction(pred, twist, moved_xy)
