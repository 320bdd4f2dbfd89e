"""`graph`: the pose-graph SLAM of the Cartographer family (Hess, Kohler, Rapp, Andor: "Real-time
loop closure in 2D LIDAR SLAM", ICRA 2016). The method step by step, with what differs from
Cartographer: docs/algorithms/graph.md.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from worlds.grid import Grid
from slam.base import ImuWindow, OdomDelta, Scan, Slam
from slam.graph.calibration import corrected_imu, gyro_bias_from_yaw, gyro_integral
from slam.graph.config import GraphConfig
from slam.graph.defaults import derive_graph_config
from slam.graph.local import LocalSlam
from slam.graph.pose_graph import PoseGraph
from slam.output_map import output_map_from_trajectory
from slam.pose import compose, relative

__all__ = ["GraphSlam"]


class GraphSlam(Slam):
    """Local SLAM with submaps + branch-and-bound loop closure + sparse pose adjustment
    (deterministic: the rng is not used)."""

    config_class = GraphConfig
    family = "Cartographer"
    compile_cost_s = 13.0   # s, cold, its own kernels (docs/benchmark.md#cost)
    deterministic = True   # no draw from rng: every SLAM seed gives the same run
    # the loop-closure search starts once the first submap is finished (about 250 scans on
    # the shipped worlds' routes): the warm-up has to get there to compile its kernels
    warmup_scans = 300

    @classmethod
    def derive_config(cls, sensors) -> list:
        """The values this algorithm takes from the log's sensors (slam/graph/defaults.py)."""
        return derive_graph_config(sensors)

    def __init__(self, config: GraphConfig, start: np.ndarray, rng: np.random.Generator):
        super().__init__(config, start, rng)
        self.local = LocalSlam(config.trajectory_builder, start)
        self.graph = PoseGraph(config.pose_graph, self.local.submaps.all,
                               config.trajectory_builder.randomized_voxel_filter)
        self.scans: list[Scan] = []
        self.scan_local: list[np.ndarray] = []
        self.scan_node: list[int] = []
        self._start = np.asarray(start, dtype=np.float64).copy()
        # calibrate_gyro: every input kept for the second pass, and the bias it used
        self._inputs: list[tuple] | None = [] if config.calibrate_gyro else None
        self.calibrated_gyro_bias: float | None = None

    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None) -> np.ndarray:
        """1. local SLAM: match the scan into the active submaps (and insert it there if the
        motion filter lets it through); 2. global SLAM: a scan that became a node is added to
        the pose graph, which searches loop closures and optimizes every N nodes;
        3. the pose is the local pose under the local-to-global correction."""
        r = self.local.add_scan(scan, odom, imu)
        if r.is_node:
            self.graph.add_node(r.pose, r.hits, r.inserted_into, r.created, r.finished, r.origin, r.normals)
        self.scans.append(scan)
        if self._inputs is not None:
            self._inputs.append((odom, imu))
        self.scan_local.append(r.pose)
        self.scan_node.append(len(self.graph.node_local) - 1)
        return compose(self.graph.correction, r.pose)

    def finish(self) -> None:
        """Loop closures for the submaps still being built, then a last optimization of the
        whole graph (PoseGraph.finish_trajectory); with calibrate_gyro, then the second run
        (_second_pass)."""
        self.graph.finish_trajectory([s.index for s in self.local.submaps.active])
        if self._inputs is not None and self.config.trajectory_builder.use_imu_data:
            self._second_pass()

    def _second_pass(self) -> None:
        """calibrate_gyro: read the gyro's mean bias from this run's optimized yaw and run the
        log again with it taken out (and the local matcher's rotation pull at
        calibrated_rotation_weight); this run's state becomes the second's. A log without a
        gyro reading between every two scans keeps the first run."""
        times, poses = self.trajectory()
        imus = [imu for _, imu in self._inputs]
        integral = gyro_integral(times, imus)
        if integral is None:
            return
        bias = gyro_bias_from_yaw(times, poses[:, 2], integral)
        tb = self.config.trajectory_builder
        matcher = dataclasses.replace(tb.ceres_scan_matcher, rotation_weight=self.config.calibrated_rotation_weight)
        config = dataclasses.replace(self.config, calibrate_gyro=False,
                                     trajectory_builder=dataclasses.replace(tb, ceres_scan_matcher=matcher))
        second = GraphSlam(config, self._start, self.rng)
        for scan, (odom, imu) in zip(self.scans, self._inputs):
            second.update(scan, odom, corrected_imu(imu, bias, times[0]))
        second.finish()
        self.local, self.graph = second.local, second.graph
        self.scan_local, self.scan_node = second.scan_local, second.scan_node
        self.calibrated_gyro_bias = bias
        self._inputs = None

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """Optimized node poses; scans between nodes placed by the local SLAM's motion since
        the latest node."""
        nl = np.array(self.graph.node_local)
        ng = np.array(self.graph.node_global)
        idx = np.array(self.scan_node)
        poses = compose(ng[idx], relative(nl[idx], np.array(self.scan_local)))
        return np.array([s.t for s in self.scans]), poses

    def map(self) -> Grid:
        """The output map of every scan at its optimized pose."""
        times, poses = self.trajectory()
        return output_map_from_trajectory(self.config.output_map, self.scans, times, poses)

    def extra_stats(self) -> dict:
        return {"nodes": len(self.graph.node_local), "submaps": len(self.graph.submap_global),
                "loop_closures": len(self.graph.loops),
                "loop_closure_attempts": self.graph.builder.attempts,
                "loop_closures_rejected": self.graph.rejected,
                "loop_closures_see_through": self.graph.builder.see_through,
                "loop_closures_sliding": sum(c.slide_axis is not None for c in self.graph.loops),
                "loop_closures_ambiguous": self.graph.builder.ambiguous,
                "optimizations": self.graph.n_optimizations,
                "gyro_bias_rad_s": self.local.gyro_bias,
                **({"calibrated_gyro_bias_rad_s": self.calibrated_gyro_bias}
                   if self.calibrated_gyro_bias is not None else {})}
