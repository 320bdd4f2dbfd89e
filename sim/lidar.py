"""LDS-01-like 2D lidar: beam geometry, ray casting at each beam's time, range noise.

Timing (slam/base.py): scan_t is the time of the first beam of a revolution; beam j is
taken at scan_t + j * time_increment, from the lidar pose at that time (motion
distortion, as a spinning lidar on a moving robot has; `motion_distortion: false` casts
every beam from the pose at scan_t). Angles are counter-clockwise in the lidar frame from
0. No return, a reading outside [range_min, range_max] or a dropped beam is inf.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim._raycast import cast_rays_indexed, segment_grid
from sim.noise import LidarNoise

__all__ = ["LidarConfig", "beam_poses", "cast_scans", "apply_range_noise"]


@dataclass(frozen=True)
class LidarConfig:
    """ROBOTIS LDS-01 (HLS-LFCD2) datasheet and turtlebot3_burger URDF."""

    beams: int = 360                  # 1 degree apart
    rate: float = 5.0                 # revolutions per second
    range_min: float = 0.12           # m
    range_max: float = 3.5            # m
    range_resolution: float = 0.001   # m, ranges are quantised to this
    offset: tuple[float, float, float] = (-0.032, 0.0, 0.0)  # x, y, yaw in the base frame
    motion_distortion: bool = True

    def __post_init__(self):
        if self.beams < 1:
            raise ValueError("beams must be >= 1")
        if self.rate <= 0:
            raise ValueError("rate must be > 0")
        if not 0 <= self.range_min < self.range_max:
            raise ValueError("need 0 <= range_min < range_max")
        if self.range_resolution < 0:
            raise ValueError("range_resolution must be >= 0")

    @property
    def scan_time(self) -> float:
        """s per revolution."""
        return 1.0 / self.rate

    @property
    def time_increment(self) -> float:
        """s between consecutive beams."""
        return self.scan_time / self.beams

    @property
    def angles(self) -> np.ndarray:
        """(beams,) rad, lidar frame, counter-clockwise from 0."""
        return np.arange(self.beams) * (2.0 * np.pi / self.beams)

    def meta(self) -> dict:
        return {"beams": self.beams, "rate": self.rate, "range_min": self.range_min,
                "range_max": self.range_max, "range_resolution": self.range_resolution,
                "offset": list(self.offset), "scan_time": self.scan_time,
                "time_increment": self.time_increment, "motion_distortion": self.motion_distortion}


def beam_poses(scan_t: np.ndarray, gt_t: np.ndarray, gt_pose: np.ndarray,
               cfg: LidarConfig) -> tuple[np.ndarray, np.ndarray]:
    """Lidar origin and world beam angle of every beam.

    scan_t: (N,) s; gt_t: (L,) s increasing; gt_pose: (L, 3) with yaw unwrapped (continuous).
    Returns origins (N, B, 2) m and angles (N, B) rad (world frame).
    """
    inc = cfg.time_increment if cfg.motion_distortion else 0.0
    t = scan_t[:, None] + np.arange(cfg.beams)[None, :] * inc          # (N, B)
    x = np.interp(t, gt_t, gt_pose[:, 0])
    y = np.interp(t, gt_t, gt_pose[:, 1])
    yaw = np.interp(t, gt_t, gt_pose[:, 2])
    ox, oy, oyaw = cfg.offset
    c, s = np.cos(yaw), np.sin(yaw)
    origins = np.stack([x + c * ox - s * oy, y + s * ox + c * oy], axis=-1)
    angles = yaw + oyaw + cfg.angles[None, :]
    return origins, angles


def cast_scans(segments: np.ndarray, origins: np.ndarray, angles: np.ndarray,
               max_range: float, cell: float = 0.5) -> np.ndarray:
    """True ranges (N, B) m (inf = nothing within max_range) for origins (N, B, 2) and
    world angles (N, B); segments (S, 4). Each beam tests only the segments filed in the
    cells (`cell` m) of a uniform grid it crosses (sim._raycast.cast_rays_indexed)."""
    n, b = angles.shape
    seg = np.ascontiguousarray(segments, dtype=np.float64).reshape(-1, 4)
    grid = segment_grid(seg, cell)
    out = cast_rays_indexed(seg, *grid, np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 2),
                            np.ascontiguousarray(angles, dtype=np.float64).reshape(-1), float(max_range))
    return out.reshape(n, b)


def apply_range_noise(ranges: np.ndarray, noise: LidarNoise, cfg: LidarConfig,
                      rng: np.random.Generator) -> np.ndarray:
    """Measured ranges (same shape as `ranges`, m): Gaussian noise per the profile,
    quantised to range_resolution; inf for no return, readings outside
    [range_min, range_max] and dropped beams (probability noise.drop_prob)."""
    r = np.asarray(ranges, dtype=np.float64)
    gauss = rng.standard_normal(r.shape)
    drop = rng.random(r.shape) < noise.drop_prob
    finite = np.isfinite(r)
    rf = np.where(finite, r, 0.0)
    accuracy = np.where(rf < noise.split, noise.near_accuracy, noise.far_accuracy_ratio * rf)
    sigma = np.sqrt(noise.stddev ** 2 + (accuracy / noise.accuracy_sigmas) ** 2)
    meas = rf + sigma * gauss
    if cfg.range_resolution > 0:
        meas = np.round(meas / cfg.range_resolution) * cfg.range_resolution
    ok = finite & ~drop & (meas >= cfg.range_min) & (meas <= cfg.range_max)
    return np.where(ok, meas, np.inf)
