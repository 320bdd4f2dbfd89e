"""Scan preprocessing: a raw lidar revolution -> end points in the robot (base) frame.

Steps: range limits (NaN and readings below range_min dropped; inf or >= range_max = no
return), optional smoothing over neighbouring beams, the lidar mounting offset, and motion
de-skew: beam j is taken at scan.t + j * time_increment (slam/base.py), so with the robot
moving at a constant twist (v_x, v_y, w) during the revolution, the beam's pose relative to
the robot at scan.t is the SE(2) exponential of twist * j * time_increment. The points come
out expressed in the robot frame at scan.t, the time the SLAM's pose refers to.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam._kernels.smooth import smooth_ranges as _smooth
from slam.base import ImuWindow, Scan
from slam.pose import relative

__all__ = ["PreprocessConfig", "ScanPoints", "preprocess", "twist_from_poses", "yaw_rate_from_imu",
           "motion_during", "smooth_ranges"]


@dataclass(frozen=True)
class PreprocessConfig:
    """How scans are cleaned before use (shared by every algorithm)."""

    range_min: float = 0.0    # m; readings below max(this, the sensor's range_min) are dropped
    range_max: float = 0.0    # m; 0 = the sensor's range_max; readings at or beyond it are "no return"
    deskew: bool = True       # undo the motion during the revolution when a twist is known
    free_range: float = 0.0   # m; no-return beams mark free space up to this range (0 = ignore them)
    smooth_beams: int = 0     # half window: each hit point is replaced by the mean of its 2k+1
                              #   neighbouring hit beams (range noise / sqrt(2k+1) on flat walls; 0 = off)
    smooth_jump: float = 0.1  # neighbours whose range differs by more than this fraction are left out

    def __post_init__(self):
        for name in ("range_min", "range_max", "free_range", "smooth_beams", "smooth_jump"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass(frozen=True, eq=False)
class ScanPoints:
    """A preprocessed scan, all in the robot frame at scan.t.

    points: (N, 2) m end points of beams that hit something; misses: (M, 2) m points at
    free_range along no-return beams; origin: (2,) m the lidar position (ray origin).
    """

    points: np.ndarray
    misses: np.ndarray
    origin: np.ndarray


def motion_during(twist: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """(K, 3) robot poses at times tau (K,) s relative to tau = 0, for a constant twist (3,)
    (v_x m/s, v_y m/s, w rad/s in the robot frame): the SE(2) exponential."""
    vx, vy, w = (float(v) for v in twist)
    tau = np.asarray(tau, dtype=np.float64)
    th = w * tau
    if abs(w) > 1e-9:
        sin_t, one_cos = np.sin(th), 1.0 - np.cos(th)
        dx = (vx * sin_t - vy * one_cos) / w
        dy = (vx * one_cos + vy * sin_t) / w
    else:
        dx, dy = vx * tau, vy * tau
    return np.stack([dx, dy, th], axis=-1)


def smooth_ranges(ranges: np.ndarray, valid: np.ndarray, half: int, jump: float, step: float,
                  circular: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Mean point of each valid beam's 2*half+1 angular neighbours, in the centre beam's frame.

    ranges: (B,) m; valid: (B,) bool; step: rad between neighbouring beams; circular: the
    beams close a full revolution (beam B-1 neighbours beam 0). Neighbours that are invalid
    or whose range differs from the centre beam's by more than `jump` * range (an occluding
    edge) are left out, so depth jumps keep sharp edges. Returns (along (B,), across (B,)) m:
    the mean point along the centre beam and across it (to its left).
    Averaging the points of a flat surface keeps them on the surface and divides the range
    noise by up to sqrt(2*half + 1); the window is about 2 * half * range * step wide.
    """
    r = np.ascontiguousarray(np.where(valid, ranges, 0.0), dtype=np.float64)
    return _smooth(r, np.ascontiguousarray(valid, dtype=np.bool_), int(half), float(jump), float(step),
                   bool(circular))


def preprocess(scan: Scan, cfg: PreprocessConfig = PreprocessConfig(),
               twist: np.ndarray | None = None) -> ScanPoints:
    """Clean `scan` and return its points in the robot frame at scan.t.

    twist: (3,) v_x, v_y (m/s), w (rad/s) in the robot frame during the revolution, or None
    (no de-skew). Ranges in m, angles in rad.
    """
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    angles = np.asarray(scan.angles, dtype=np.float64)
    idx = np.arange(len(ranges))
    r = ranges
    rmin = max(cfg.range_min, float(scan.range_min), 0.0)
    rmax = cfg.range_max if cfg.range_max > 0 else float(scan.range_max)
    with np.errstate(invalid="ignore"):
        hit = np.isfinite(r) & (r > rmin) & (r < rmax)
        miss = (np.isposinf(r) | (np.isfinite(r) & (r >= rmax))) if cfg.free_range > 0 else np.zeros(len(r), bool)
    off = np.asarray(scan.offset, dtype=np.float64)
    across = np.zeros(len(r))
    if cfg.smooth_beams > 0 and hit.any():
        # beams are equally spaced over the revolution: the fan's angle step is the beams' step
        step = float(np.median(np.diff(angles))) if len(angles) > 1 else 0.0
        full = len(angles) > 1 and abs(step * len(angles) - 2 * np.pi) < 1e-6
        along, across = smooth_ranges(r, hit, cfg.smooth_beams, cfg.smooth_jump, step, full)
        r = np.where(hit, along, r)

    def to_robot(beams: np.ndarray, rng_: np.ndarray, side: np.ndarray | None = None) -> np.ndarray:
        a = angles[beams] + off[2]
        ca, sa = np.cos(a), np.sin(a)
        if side is None:
            side = np.zeros(len(beams))
        local = np.stack([off[0] + rng_ * ca - side * sa, off[1] + rng_ * sa + side * ca], axis=1)
        if cfg.deskew and twist is not None and scan.time_increment > 0 and len(beams):
            m = motion_during(twist, beams * scan.time_increment)
            c, s = np.cos(m[:, 2]), np.sin(m[:, 2])
            local = np.stack([m[:, 0] + c * local[:, 0] - s * local[:, 1],
                              m[:, 1] + s * local[:, 0] + c * local[:, 1]], axis=1)
        return local

    hb = idx[hit]
    points = to_robot(hb, r[hit], across[hit])
    mb = idx[miss]
    misses = to_robot(mb, np.full(len(mb), min(cfg.free_range, rmax))) if len(mb) else np.zeros((0, 2))
    return ScanPoints(np.ascontiguousarray(points), np.ascontiguousarray(misses), off[:2].copy())


def twist_from_poses(prev_pose: np.ndarray, pose: np.ndarray, dt: float) -> np.ndarray:
    """(3,) constant twist that moves prev_pose to pose in dt s (robot frame of prev_pose)."""
    if dt <= 0:
        return np.zeros(3)
    d = relative(prev_pose, pose)
    return d / dt


def yaw_rate_from_imu(imu: ImuWindow | None) -> float | None:
    """Mean gyro yaw rate (rad/s) over the window, None without samples."""
    if imu is None or len(imu.gyro) == 0:
        return None
    return float(np.mean(imu.gyro))
