"""The oracle: maps every scan at the robot's true pose with the same map building as the
SLAMs' output maps (slam.mapper). Its map is the best the sensor and the route allow, the
benchmark's ceiling; it is the only algorithm that reads ground truth (`needs_ground_truth`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from worlds.grid import Grid
from slam.base import ImuWindow, OdomDelta, Scan, register
from slam.mapper import Mapper, MapperConfig
from slam.preprocess import twist_from_poses

__all__ = ["OracleConfig", "OracleSlam"]


@dataclass(frozen=True)
class OracleConfig:
    """Oracle mapping: only the map building (same fields and defaults as gn's output_map)."""

    map: MapperConfig = field(default_factory=MapperConfig)


@register("oracle")
class OracleSlam:
    """Occupancy mapping at the true poses, de-skewed with the true motion during each revolution."""

    config_class = OracleConfig
    needs_ground_truth = True

    def __init__(self, cfg: OracleConfig, start: np.ndarray, rng: np.random.Generator):
        self.cfg = cfg
        self.mapper = Mapper(cfg.map, center=start[:2])
        self._times: list[float] = []
        self._poses: list[np.ndarray] = []
        self._pending: tuple[Scan, np.ndarray] | None = None
        self._twist: np.ndarray | None = None

    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None,
               truth: np.ndarray | None = None) -> np.ndarray:
        pose = np.asarray(truth, dtype=np.float64).copy()
        # a revolution spans [t_i, t_i+1): it is inserted once the next true pose is known,
        # so its de-skew uses the true motion during it (the last one reuses the previous motion)
        if self._pending is not None:
            prev_scan, prev_pose = self._pending
            self._twist = twist_from_poses(prev_pose, pose, scan.t - prev_scan.t)
            self.mapper.insert(prev_scan, prev_pose, self._twist)
        self._pending = (scan, pose)
        self._times.append(scan.t)
        self._poses.append(pose)
        return pose

    def map(self) -> Grid:
        return self.mapper.to_grid()

    def finish(self) -> None:
        if self._pending is not None:
            self.mapper.insert(*self._pending, self._twist)
            self._pending = None

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self._times, dtype=np.float64), np.asarray(self._poses, dtype=np.float64).reshape(-1, 3)
