"""The oracle: maps every scan at the robot's true pose with the output map every algorithm
uses (slam.output_map). Its map is the best the sensor and the route allow, the benchmark's
ceiling; it is the only algorithm that reads ground truth (`uses_ground_truth`).
"""
from __future__ import annotations

import numpy as np

from worlds.grid import Grid
from slam.base import ImuWindow, OdomDelta, Scan, Slam
from slam.oracle.config import OracleConfig
from slam.output_map import OutputMap
from slam.preprocess import twist_from_poses

__all__ = ["OracleSlam"]


class OracleSlam(Slam):
    """Occupancy mapping at the true poses, de-skewed with the true motion during each revolution."""

    config_class = OracleConfig
    uses_ground_truth = True
    compile_cost_s = 0.5   # s, cold, its own kernels (docs/benchmark.md#cost)
    deterministic = True   # no draw from rng: every SLAM seed gives the same run

    def __init__(self, config: OracleConfig, start: np.ndarray, rng: np.random.Generator):
        super().__init__(config, start, rng)
        self.output = OutputMap(config.output_map, center=start[:2])
        self._times: list[float] = []
        self._poses: list[np.ndarray] = []
        self._pending: tuple[Scan, np.ndarray] | None = None
        self._twist: np.ndarray | None = None

    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None,
               truth: np.ndarray | None = None) -> np.ndarray:
        """1. take the true pose; 2. insert the previous scan, de-skewed with the true motion
        from it to this one (a revolution spans [t_i, t_i+1)); 3. keep this scan for the next."""
        pose = np.asarray(truth, dtype=np.float64).copy()
        if self._pending is not None:
            prev_scan, prev_pose = self._pending
            self._twist = twist_from_poses(prev_pose, pose, scan.t - prev_scan.t)
            self.output.insert(prev_scan, prev_pose, self._twist)
        self._pending = (scan, pose)
        self._times.append(scan.t)
        self._poses.append(pose)
        return pose

    def finish(self) -> None:
        """Insert the last scan with the motion before it."""
        if self._pending is not None:
            self.output.insert(*self._pending, self._twist)
            self._pending = None

    def map(self) -> Grid:
        return self.output.to_grid()

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self._times, dtype=np.float64), np.asarray(self._poses, dtype=np.float64).reshape(-1, 3)
