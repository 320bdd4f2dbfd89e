"""`gn`: Gauss-Newton scan-to-map SLAM, the Hector SLAM family (Kohlbrecher, von Stryk,
Meyer, Klingauf: "A flexible and scalable SLAM system with full 3D motion estimation",
SSRR 2011; the hector_mapping ROS package). The method step by step, with what differs
from hector_mapping: docs/algorithms/gn.md.
"""
from __future__ import annotations

import math

import numpy as np

from worlds.grid import Grid
from slam.base import ImuWindow, OdomDelta, Scan, Slam
from slam.gn.config import GnConfig
from slam.gn.defaults import derive_gn_config
from slam.gn.levels import MapLevels
from slam.gn.matching import match_scan
from slam.gn.motion import Prediction, predict
from slam.gn.priors import degenerate_direction, motion_prior, surface_normals
from slam.output_map import OutputMap
from slam.pose import relative, transform_points
from slam.preprocess import ScanPoints, preprocess, sweep_twist

__all__ = ["GaussNewtonSlam"]


class GaussNewtonSlam(Slam):
    """Hector-style SLAM: scan-to-map Gauss-Newton on a multi-resolution occupancy map."""

    config_class = GnConfig
    family = "Hector"
    compile_cost_s = 2.0   # s, cold, its own kernels (docs/benchmark.md#cost)
    deterministic = True   # no draw from rng: every SLAM seed gives the same run

    @classmethod
    def derive_config(cls, sensors) -> list:
        """The values this algorithm takes from the log's sensors (slam/gn/defaults.py)."""
        return derive_gn_config(sensors)

    def __init__(self, config: GnConfig, start: np.ndarray, rng: np.random.Generator):
        super().__init__(config, start, rng)
        self.maps = MapLevels(config, start[:2])
        self.output = OutputMap(config.output_map, center=start[:2])
        self.pose = np.asarray(start, dtype=np.float64).copy()
        self._last_update_pose: np.ndarray | None = None
        self._times: list[float] = []
        self._poses: list[np.ndarray] = []
        self._map_updates = 0
        self._degenerate_scans = 0

    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None) -> np.ndarray:
        """1. predict (gyro yaw, estimates' velocity); 2. preprocess and de-skew the scan;
        3. match it coarse to fine against the map levels (the first scan: the start pose);
        4. update the map levels once the robot moved far enough; 5. insert it into the
        output map at the matched pose."""
        prediction = predict(self.config, self.pose, self._times, self._poses, scan.t, imu)
        # the gyro of the scan's own revolution turns the de-skew (no wheel odometry here)
        twist = sweep_twist(scan, None, imu if self.config.use_imu else None, prediction.twist)
        pts = preprocess(scan, self.config.preprocess, twist)
        if self._last_update_pose is not None and len(pts.points):
            self.pose = self._match(pts, prediction, imu)
        else:
            self.pose = prediction.pose
        if self._map_update_due():
            self._update_maps(pts)
        self.output.insert(scan, self.pose, twist)
        self._times.append(scan.t)
        self._poses.append(self.pose.copy())
        return self.pose

    def _match(self, pts: ScanPoints, prediction: Prediction, imu: ImuWindow | None) -> np.ndarray:
        """The matched pose (3,) of the scan's points under the motion priors."""
        cfg = self.config
        points = np.ascontiguousarray(pts.points, dtype=np.float64)
        normals = surface_normals(cfg, points)
        observed = (self.maps.observed(transform_points(prediction.pose, points))
                    if cfg.degeneracy_threshold > 0 else None)
        degenerate = degenerate_direction(cfg, normals, observed, prediction.pose)
        self._degenerate_scans += degenerate is not None
        has_gyro = cfg.use_imu and imu is not None and len(imu.gyro) > 0
        prior, info = motion_prior(cfg, prediction.pose, prediction.moved_xy, len(points),
                                   has_gyro, len(self._poses) > 1, degenerate)
        return match_scan(self.maps.images(), points, prediction.pose, self.maps.iterations,
                          cfg.max_angle_step, cfg.check_prior, prior, info,
                          normals if cfg.gradient_along_normal else None)

    def _map_update_due(self) -> bool:
        """Hector's rule: the first scan, then after map_update_distance/angle_thresh of motion."""
        if self._last_update_pose is None:
            return True
        d = relative(self._last_update_pose, self.pose)
        return (math.hypot(d[0], d[1]) > self.config.map_update_distance_thresh
                or abs(d[2]) > self.config.map_update_angle_thresh)

    def _update_maps(self, pts: ScanPoints) -> None:
        self.maps.insert(pts, self.pose)
        self._last_update_pose = self.pose.copy()
        self._map_updates += 1

    def map(self) -> Grid:
        return self.output.to_grid()

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self._times, dtype=np.float64), np.asarray(self._poses, dtype=np.float64).reshape(-1, 3)

    def extra_stats(self) -> dict:
        return {"map_updates": self._map_updates, "degenerate_scans": self._degenerate_scans}
