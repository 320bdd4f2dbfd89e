"""SE(2) pose algebra on (3,) or (N, 3) arrays x, y, yaw (yaw wrapped to (-pi, pi])."""
from __future__ import annotations

import math

import numpy as np

__all__ = ["wrap_angle", "compose", "inverse", "relative", "transform_points", "interpolate_poses"]


def _wrap_scalar(a: float) -> float:
    w = (a + math.pi) % (2.0 * math.pi) - math.pi
    return math.pi if w == -math.pi else w


def wrap_angle(a):
    """Angle(s) wrapped to (-pi, pi]."""
    if isinstance(a, (float, int, np.floating)):   # the SLAMs' per-scan calls: no array round trip
        return _wrap_scalar(float(a))
    w = np.mod(np.asarray(a, dtype=np.float64) + np.pi, 2 * np.pi) - np.pi
    w = np.where(w == -np.pi, np.pi, w)
    return float(w) if np.ndim(w) == 0 else w


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a (+) b: pose b expressed in frame a, returned in a's parent frame. Broadcasts over rows."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape == (3,) and b.shape == (3,):       # one pose each: scalar arithmetic is 5x faster
        c, s = math.cos(a[2]), math.sin(a[2])
        return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1],
                         _wrap_scalar(a[2] + b[2])])
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a: np.ndarray) -> np.ndarray:
    """(-) a: the pose whose composition with a is the identity."""
    a = np.asarray(a, dtype=np.float64)
    if a.shape == (3,):
        c, s = math.cos(a[2]), math.sin(a[2])
        return np.array([-c * a[0] - s * a[1], s * a[0] - c * a[1], _wrap_scalar(-a[2])])
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -c * a[..., 0] - s * a[..., 1]
    y = s * a[..., 0] - c * a[..., 1]
    return np.stack([x, y, wrap_angle(-a[..., 2])], axis=-1)


def relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(-) a (+) b: pose b in the frame of pose a."""
    return compose(inverse(a), b)


def transform_points(pose: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """(N, 2) points in the frame `pose` -> (N, 2) points in the parent frame."""
    pose = np.asarray(pose, dtype=np.float64)
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.stack([pose[0] + c * pts[:, 0] - s * pts[:, 1],
                     pose[1] + s * pts[:, 0] + c * pts[:, 1]], axis=1)


def interpolate_poses(t_query: np.ndarray, t: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Poses at times t_query by linear interpolation (yaw unwrapped), clamped at the ends.

    t_query: (Q,) s; t: (N,) s, increasing; poses: (N, 3). Returns (Q, 3).
    """
    t_query = np.atleast_1d(np.asarray(t_query, dtype=np.float64))
    poses = np.asarray(poses, dtype=np.float64)
    if len(t) == 0:
        raise ValueError("interpolate_poses: no poses to interpolate")
    yaw = np.unwrap(poses[:, 2])
    out = np.empty((len(t_query), 3))
    out[:, 0] = np.interp(t_query, t, poses[:, 0])
    out[:, 1] = np.interp(t_query, t, poses[:, 1])
    out[:, 2] = wrap_angle(np.interp(t_query, t, yaw))
    return out
