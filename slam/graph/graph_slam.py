"""GraphSlam: the pose-graph SLAM of the Cartographer family (Hess et al. 2016).

    update(scan):  local SLAM matches the scan into the active submaps
                   -> if it became a node: global SLAM adds it, searches loop closures,
                      optimizes every N nodes
                   -> pose = local-to-global correction (+) local pose
    finish():      a last optimization
    map():         every node's scan re-inserted at its optimized pose into one grid
    trajectory():  optimized node poses; scans between nodes placed by the local SLAM's
                   motion relative to the latest node
"""
from __future__ import annotations

import numpy as np

from worlds.grid import Grid
from slam.base import ImuWindow, OdomDelta, Scan, register
from slam.occupancy import LogOddsGrid, logodds
from slam.pose import compose, relative, transform_points
from slam.graph.config import GraphConfig
from slam.graph.final_map import sharpened_map
from slam.graph.local import LocalSlam
from slam.graph.pose_graph import PoseGraph
from slam.mapper import Mapper
from slam.preprocess import twist_from_poses

__all__ = ["GraphSlam"]


@register("graph")
class GraphSlam:
    """Local SLAM with submaps + branch-and-bound loop closure + sparse pose adjustment."""

    config_class = GraphConfig

    def __init__(self, cfg: GraphConfig, start: np.ndarray, rng: np.random.Generator):
        self.cfg = cfg
        self.rng = rng                        # unused: the algorithm is deterministic
        self.local = LocalSlam(cfg.trajectory_builder, start)
        self.graph = PoseGraph(cfg.pose_graph, self.local.submaps.all,
                               cfg.trajectory_builder.randomized_voxel_filter)
        self.times: list[float] = []
        self.scan_local: list[np.ndarray] = []
        self.scan_node: list[int] = []
        self.node_scans: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.scans: list[Scan] = []           # kept for final_map "mapper"

    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None) -> np.ndarray:
        r = self.local.add_scan(scan, odom, imu)
        if r.is_node:
            odometry = odom.pose if odom is not None and self.cfg.trajectory_builder.use_odometry else None
            self.graph.add_node(r.pose, r.hits, r.inserted_into, r.created, r.finished, r.origin, odometry)
            self.node_scans.append((r.origin, r.hits, r.misses))
        self.times.append(scan.t)
        if self.cfg.final_map == "mapper":
            self.scans.append(scan)
        self.scan_local.append(r.pose)
        self.scan_node.append(len(self.graph.node_local) - 1)
        return compose(self.graph.correction, r.pose)

    def finish(self) -> None:
        self.graph.optimize()

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        nl = np.array(self.graph.node_local)
        ng = np.array(self.graph.node_global)
        idx = np.array(self.scan_node)
        loc = np.array(self.scan_local)
        poses = compose(ng[idx], relative(nl[idx], loc))
        return np.array(self.times), poses

    def map(self) -> Grid:
        if self.cfg.final_map == "mapper":
            return self._mapper_map()
        if self.cfg.final_map == "sharpened":
            return sharpened_map(np.array(self.graph.node_global), self.node_scans, self.cfg.map_resolution,
                                 self.cfg.map_near_range, self.cfg.map_suppress_ratio, self.cfg.map_max_range)
        sub = self.cfg.trajectory_builder.submaps
        grid = LogOddsGrid(self.cfg.map_resolution, center=tuple(self.graph.node_global[0][:2]),
                           l_free=logodds(sub.miss_probability), l_occ=logodds(sub.hit_probability),
                           l_min=logodds(sub.min_probability), l_max=logodds(sub.max_probability))
        for pose, (origin, hits, misses) in zip(self.graph.node_global, self.node_scans):
            if self.cfg.map_max_range > 0:
                hits = hits[np.hypot(*(hits - origin).T) <= self.cfg.map_max_range]
            pts = np.vstack([hits, misses]) if sub.insert_free_space else hits
            mask = np.zeros(len(pts), bool)
            mask[:len(hits)] = True
            grid.insert_scan(transform_points(pose, origin[None, :])[0], transform_points(pose, pts), mask)
        return grid.to_grid()

    def _mapper_map(self) -> Grid:
        """Every scan re-inserted at its optimized pose, de-skewed with the motion to the next."""
        times, poses = self.trajectory()
        mapper = Mapper(self.cfg.output_map, center=tuple(poses[0][:2]))
        for i, scan in enumerate(self.scans):
            j, k = (i, i + 1) if i + 1 < len(poses) else (i - 1, i)
            twist = twist_from_poses(poses[j], poses[k], times[k] - times[j]) if j >= 0 else np.zeros(3)
            mapper.insert(scan, poses[i], twist)
        return mapper.to_grid()

    def extra_stats(self) -> dict:
        return {"nodes": len(self.graph.node_local), "submaps": len(self.graph.submap_global),
                "loop_closures": len(self.graph.loops),
                "loop_closure_attempts": self.graph.builder.attempts,
                "loop_closures_rejected": self.graph.rejected,
                "loop_closures_see_through": self.graph.builder.see_through,
                "optimizations": self.graph.n_optimizations}
