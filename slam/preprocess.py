"""Scan preprocessing: a raw lidar revolution -> end points in the robot (base) frame.

Steps: range limits (NaN and readings below range_min dropped; inf or >= range_max = no
return), optional smoothing over neighbouring beams, the lidar mounting offset, and motion
de-skew: beam j is taken at scan.t + j * time_increment (slam/base.py), so with the robot
moving at a constant twist (v_x, v_y, w) during the revolution, the beam's pose relative to
the robot at scan.t is the SE(2) exponential of twist * j * time_increment. The points come
out expressed in the robot frame at scan.t, the time the SLAM's pose refers to.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from slam._kernels.beams import scan_points
from slam.base import ImuWindow, OdomDelta, Scan
from slam.pose import relative

__all__ = ["PreprocessConfig", "ScanPoints", "preprocess", "twist_from_poses", "yaw_rate_from_imu",
           "sweep_twist", "CENSOR_HALF_WINDOW", "censored_hits", "without_censored_hits"]

_NO_TWIST = np.zeros(3)

# censored_hits: beams on either side whose readings tell how far the surface lies
CENSOR_HALF_WINDOW = 4


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


def preprocess(scan: Scan, cfg: PreprocessConfig = PreprocessConfig(),
               twist: np.ndarray | None = None) -> ScanPoints:
    """Clean `scan` and return its points in the robot frame at scan.t
    (slam/_kernels/beams.py).

    twist: (3,) v_x, v_y (m/s), w (rad/s) in the robot frame during the revolution, or None
    (no de-skew). Ranges in m, angles in rad.
    """
    rmin = max(cfg.range_min, float(scan.range_min), 0.0)
    rmax = cfg.range_max if cfg.range_max > 0 else float(scan.range_max)
    off = np.asarray(scan.offset, dtype=np.float64)
    deskew = cfg.deskew and twist is not None and scan.time_increment > 0
    points, misses = scan_points(
        np.asarray(scan.ranges, dtype=np.float64), np.asarray(scan.angles, dtype=np.float64),
        off, rmin, rmax, float(cfg.free_range), int(cfg.smooth_beams), float(cfg.smooth_jump),
        np.asarray(twist if deskew else _NO_TWIST, dtype=np.float64),
        float(scan.time_increment), bool(deskew))
    return ScanPoints(points, misses, off[:2].copy())


def twist_from_poses(prev_pose: np.ndarray, pose: np.ndarray, dt: float) -> np.ndarray:
    """(3,) constant twist that moves prev_pose to pose in dt s (robot frame of prev_pose)."""
    if dt <= 0:
        return np.zeros(3)
    d = relative(prev_pose, pose)
    return d / dt


def yaw_rate_from_imu(imu: ImuWindow | None, t0: float, t1: float) -> float | None:
    """Mean gyro yaw rate (rad/s) over (t0, t1], the window's interval, None without samples:
    each sample's rate held since the sample before it (the first from t0; the last held to
    t1), i.e. the rates integrated by their timestamps.

    Not the mean of the samples: a 100 Hz gyro's window of 0.2 s holds 19, 20 or 21 samples
    as float timestamps fall either side of its edges, and in a jerky turn the sample mean
    drifted by 0.6 degrees in 12 s where the integral stays within 0.2 of the truth."""
    if imu is None or len(imu.gyro) == 0:
        return None
    if t1 <= t0:
        return float(np.mean(imu.gyro))
    ts = np.clip(np.asarray(imu.t, dtype=np.float64), t0, t1)
    held = np.diff(ts, prepend=t0)
    held[-1] += t1 - ts[-1]
    return float(np.dot(np.asarray(imu.gyro, dtype=np.float64), held) / (t1 - t0))


def sweep_twist(scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None,
                fallback: np.ndarray | None) -> np.ndarray | None:
    """(3,) twist of the robot during the scan's own revolution, for de-skewing it: translation
    from the odometry over the revolution, rotation from the gyro samples taken in it (else the
    odometry's); a part neither measured comes from `fallback` (the caller's estimate, e.g. the
    motion since the previous scan), which is returned as it is when neither was measured.

    The motion before the scan is a lagging guess in a turn that starts or reverses; the first
    scan of a run has none. Pass odom=None or imu=None to leave a sensor out.
    """
    span = scan.sweep_time
    odom_twist = (twist_from_poses(odom.pose, odom.sweep_end, span)
                  if span > 0 and odom is not None and odom.sweep_end is not None else None)
    gyro = imu.sweep_gyro if imu is not None and span > 0 else ()
    if odom_twist is None and len(gyro) == 0:
        return fallback
    if odom_twist is not None:
        twist = odom_twist
    else:
        twist = np.zeros(3) if fallback is None else np.array(fallback, dtype=np.float64)
    if len(gyro):
        twist[2] = float(np.mean(gyro))
    return twist


def censored_hits(ranges: np.ndarray, range_max: float, sigma: float, margin_sigmas: float,
                  half_window: int = CENSOR_HALF_WINDOW) -> np.ndarray:
    """(B,) bool: the hits among the ranges (B,) m (a revolution, inf or >= range_max = no
    return) of surfaces within margin_sigmas sigma of the maximum range, sigma (m) the range
    noise there. margin_sigmas <= 0: none.

    A lidar returns nothing for a reading beyond its maximum range, so of a wall near it only
    the short readings come back, and they put it nearer than it is: a wall at range_max -
    2 sigma keeps 98 % of its readings, 0.06 sigma short on average, one at range_max - sigma
    84 %, 0.29 sigma short, one at range_max half, 0.8 sigma short. Where a surface lies is
    read from the other hits within half_window beams and 4 sigma of the beam's range (a
    nearer object beside it is not its surface), their mean; a hit with no such neighbour
    has only its own range. The neighbours decide, so the hits kept are not chosen by their
    own noise."""
    r = np.asarray(ranges, dtype=np.float64)
    n = len(r)
    hit = np.isfinite(r) & (r > 0) & (r < range_max)
    if margin_sigmas <= 0 or n == 0:
        return np.zeros(n, bool)
    offsets = np.concatenate([np.arange(-half_window, 0), np.arange(1, half_window + 1)])
    near = (np.arange(n)[:, None] + offsets[None, :]) % n
    hr = np.where(hit, r, np.nan)
    same = np.abs(hr[near] - hr[:, None]) < 4.0 * sigma          # NaN (not a hit) compares False
    count = same.sum(axis=1)
    surface = np.where(count > 0, np.where(same, r[near], 0.0).sum(axis=1) / np.maximum(count, 1), r)
    return hit & (surface > range_max - margin_sigmas * sigma)


def without_censored_hits(scan: Scan, range_max: float, margin_sigmas: float) -> Scan:
    """The scan with the censored_hits of its ranges dropped (NaN: neither hit nor no return),
    the noise read from its range model at range_max (m; 0: the scan's own); itself when none
    is dropped."""
    rmax = float(scan.range_max) if range_max <= 0 else min(float(range_max), float(scan.range_max))
    drop = censored_hits(scan.ranges, rmax, float(scan.range_noise.sigma(rmax)), margin_sigmas)
    if not drop.any():
        return scan
    ranges = np.array(scan.ranges, dtype=np.float64)
    ranges[drop] = np.nan
    return dataclasses.replace(scan, ranges=ranges)
