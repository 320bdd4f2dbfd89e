"""Wheel odometry from encoder ticks, as the TurtleBot3 firmware computes it.

The encoders count what the motors turned (4096 ticks per wheel revolution, Dynamixel
XL430); the pose integrates each interval's wheel travel with the nominal radius and
separation (midpoint rule): ds = (dl + dr) / 2, dyaw = (dr - dl) / separation,
x += ds cos(yaw + dyaw / 2). Slip and collisions are not seen by the encoders, so they
appear as drift against the true path.
"""
from __future__ import annotations

import numpy as np

__all__ = ["wheel_angles_at", "encoder_ticks", "integrate_ticks", "odometry_drift",
           "DRIFT_RANGE_REALISTIC"]

# Documented range of odometry drift under the `realistic` profile, as the mean position
# error of the odometry over 5 m stretches of the true path divided by 5 m
# (odometry_drift()["segment_drift"]); measured on swirl_l by tests/sim/test_record.py.
DRIFT_RANGE_REALISTIC = (0.01, 0.06)


def wheel_angles_at(times: np.ndarray, step_t: np.ndarray, wheel_speed: np.ndarray) -> np.ndarray:
    """Cumulative wheel angles (T, 2) rad (left, right) at `times` (T,) s.

    step_t: (C + 1,) boundaries of the control steps, s; wheel_speed: (C, 2) rad/s held
    constant within each step (so the angle is piecewise linear: exact interpolation).
    """
    angle = np.vstack([np.zeros((1, 2)), np.cumsum(wheel_speed * np.diff(step_t)[:, None], axis=0)])
    return np.stack([np.interp(times, step_t, angle[:, k]) for k in range(2)], axis=1)


def encoder_ticks(angles: np.ndarray, ticks_per_rev: int) -> np.ndarray:
    """Tick counts (same shape, int64) of cumulative wheel angles (rad): the encoder
    reports whole ticks only."""
    # the small epsilon (in ticks) keeps exact multiples of a tick from flipping on round-off
    return np.floor(np.asarray(angles) * (ticks_per_rev / (2 * np.pi)) + 1e-9).astype(np.int64)


def integrate_ticks(t: np.ndarray, ticks: np.ndarray, start_pose: np.ndarray, ticks_per_rev: int,
                    wheel_radius: float, wheel_separation: float) -> tuple[np.ndarray, np.ndarray]:
    """Odometry pose (M, 3) (x, y, yaw wrapped) and twist (M, 2) (v m/s, w rad/s) from
    tick counts (M, 2) at times t (M,) s, starting at start_pose (3,). Twist of sample 0: 0."""
    d = np.diff(ticks, axis=0) * (2 * np.pi / ticks_per_rev) * wheel_radius    # (M-1, 2) m
    ds = 0.5 * (d[:, 0] + d[:, 1])
    dyaw = (d[:, 1] - d[:, 0]) / wheel_separation
    yaw = start_pose[2] + np.concatenate([[0.0], np.cumsum(dyaw)])
    mid = yaw[:-1] + 0.5 * dyaw
    x = start_pose[0] + np.concatenate([[0.0], np.cumsum(ds * np.cos(mid))])
    y = start_pose[1] + np.concatenate([[0.0], np.cumsum(ds * np.sin(mid))])
    dt = np.diff(t)
    twist = np.zeros((len(t), 2))
    if len(dt):
        twist[1:, 0] = ds / dt
        twist[1:, 1] = dyaw / dt
    pose = np.stack([x, y, np.mod(yaw + np.pi, 2 * np.pi) - np.pi], axis=1)
    return pose, twist


def _relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pose(s) b in the frame of pose(s) a, (..., 3)."""
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    dyaw = np.mod(b[..., 2] - a[..., 2] + np.pi, 2 * np.pi) - np.pi
    return np.stack([c * dx + s * dy, -s * dx + c * dy, dyaw], axis=-1)


def odometry_drift(odom_t: np.ndarray, odom_pose: np.ndarray, gt_t: np.ndarray,
                   gt_pose: np.ndarray, segment: float = 5.0) -> dict:
    """How far odometry drifts from the true path.

    Returns distance (m, true path length), end_error (m, final position error),
    end_error_ratio (end_error / distance), end_yaw_error (rad), and segment_drift: for
    every odometry sample, the true pose `segment` metres of path later; the position
    error of the odometry's relative motion over that stretch divided by `segment`,
    averaged (KITTI-style, nan if the path is shorter than `segment`).
    """
    yaw_u = np.unwrap(gt_pose[:, 2])
    gt = np.stack([np.interp(odom_t, gt_t, gt_pose[:, 0]), np.interp(odom_t, gt_t, gt_pose[:, 1]),
                   np.interp(odom_t, gt_t, yaw_u)], axis=1)
    step = np.linalg.norm(np.diff(gt[:, :2], axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(step)])
    distance = float(arc[-1])
    end_error = float(np.hypot(*(odom_pose[-1, :2] - gt[-1, :2])))
    end_yaw = float(np.mod(odom_pose[-1, 2] - gt[-1, 2] + np.pi, 2 * np.pi) - np.pi)
    j = np.searchsorted(arc, arc + segment)
    ok = j < len(arc)
    i, j = np.nonzero(ok)[0], j[ok]
    if len(i):
        rel_gt = _relative(gt[i], gt[j])
        rel_od = _relative(odom_pose[i], odom_pose[j])
        err = np.hypot(rel_od[:, 0] - rel_gt[:, 0], rel_od[:, 1] - rel_gt[:, 1])
        seg_drift = float(np.mean(err / (arc[j] - arc[i])))
    else:
        seg_drift = float("nan")
    return {"distance": distance, "end_error": end_error,
            "end_error_ratio": end_error / distance if distance > 0 else float("nan"),
            "end_yaw_error": abs(end_yaw), "segment_drift": seg_drift, "segment": segment}
