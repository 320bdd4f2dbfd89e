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

from slam._kernels.beams import closes_turn, scan_points
from slam._kernels.censor import censoring_shortfall
from slam.base import ImuWindow, OdomDelta, Scan
from slam.pose import relative

__all__ = ["PreprocessConfig", "ScanPoints", "preprocess", "twist_from_poses", "yaw_rate_from_imu",
           "sweep_twist", "CENSOR_HALF_WINDOW", "CENSOR_HEADROOM_SIGMAS",
           "censoring_corrected"]

_NO_TWIST = np.zeros(3)

# censoring_corrected: beams on either side whose readings tell how far a surface lies, and
# the room above the limit for the lengthened hits (a shortfall is at most 1.53 sigma)
CENSOR_HALF_WINDOW = 4
CENSOR_HEADROOM_SIGMAS = 2.0


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


def censoring_corrected(scan: Scan, range_max: float = 0.0) -> Scan:
    """The scan with each hit lengthened by the mean shortfall the lidar's maximum range leaves
    on the readings of its surface (slam/_kernels/censor.py), range_max (m) that limit (0: the
    scan's own; no larger than it), the noise read from the scan's range model there.

    A lidar returns nothing for a reading beyond its maximum range, so of a wall near it only
    the short readings come back and they put it nearer than it is: with the LDS-01's 87.5 mm
    at 3.5 m, a wall at 3.41 m keeps 85 % of its readings, 24 mm short on average, one at
    3.5 m half, 70 mm short. The readings at or beyond the limit become inf (no return), and
    the result's range_max lies CENSOR_HEADROOM_SIGMAS above the limit, so a hit lengthened
    past it is still a hit."""
    rmax = float(scan.range_max) if range_max <= 0 else min(float(range_max), float(scan.range_max))
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    sigma = float(scan.range_noise.sigma(rmax))
    step = float(np.median(np.diff(scan.angles))) if len(ranges) > 1 else 0.0
    circular = bool(closes_turn(step, len(ranges)))
    shortfall = censoring_shortfall(ranges, rmax, sigma, CENSOR_HALF_WINDOW, circular)
    out = np.where(ranges >= rmax, np.inf, ranges + shortfall)
    return dataclasses.replace(scan, ranges=out, range_max=rmax + CENSOR_HEADROOM_SIGMAS * sigma)
