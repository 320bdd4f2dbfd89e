"""Global SLAM: nodes, submaps and constraints, optimized by sparse pose adjustment.

As Cartographer's PoseGraph2D: each node gets an intra-submap constraint to every submap it
was inserted into (its local-SLAM pose in that submap, matcher weights); consecutive nodes are
tied by their local-SLAM relative pose (local_slam_pose weights); loop-closure constraints
come from the ConstraintBuilder (new node vs finished submaps, and a newly finished submap vs
older nodes). Every optimize_every_n_nodes nodes, and at the end, all poses are optimized;
the local-to-global correction is then the one of the newest submap. At the end the submaps still
being built are searched for loop closures as finished ones (finish_trajectory).
"""
from __future__ import annotations

import numpy as np

from slam.pose import compose, inverse, relative
from slam.graph.config import GlobalConfig
from slam.graph.filters import adaptive_voxel_filter
from slam.graph.loop_closure import ConstraintBuilder, LoopConstraint
from slam.graph.optimize import Constraints, optimize_poses
from slam.graph.submaps import Submap

__all__ = ["PoseGraph"]


class PoseGraph:
    """Pose graph over nodes (kept scans) and submaps."""

    def __init__(self, cfg: GlobalConfig, submaps: list[Submap], randomized_voxel_filter: bool = False):
        self.cfg = cfg
        self.randomized_voxel_filter = randomized_voxel_filter  # for the loop-closure point filter
        self.submaps = submaps                      # shared with the local SLAM's ActiveSubmaps
        self.submap_global: list[np.ndarray] = []
        self.node_local: list[np.ndarray] = []
        self.node_global: list[np.ndarray] = []
        self.node_points: list[np.ndarray] = []     # loop-closure filtered, robot frame
        self.node_origins: list[np.ndarray] = []    # lidar position, robot frame
        self.node_normals: list[np.ndarray | None] = []    # node_points' normal angles, robot frame
        self.node_submaps: list[tuple] = []
        self.loops: list[LoopConstraint] = []
        self.builder = ConstraintBuilder(cfg.constraint_builder)
        self.correction = np.zeros(3)               # local -> global
        self.n_optimizations = 0
        self.rejected = 0
        self._since_opt = 0
        self._loops_at_opt = 0

    def add_node(self, local_pose: np.ndarray, hits: np.ndarray, inserted_into: tuple,
                 created: tuple, finished: tuple, origin: np.ndarray | None = None,
                 normals: np.ndarray | None = None) -> int:
        """Add a node (local pose (3,), hits (N, 2) robot frame seen from the lidar at origin (2,)
        robot frame, default the robot's centre, with their normal angles (N,) rad for the
        directional TSDF, or None); search loops; maybe optimize."""
        for s in created:
            while len(self.submap_global) <= s:
                self.submap_global.append(compose(self.correction, self.submaps[len(self.submap_global)].local_pose))
        node = len(self.node_local)
        self.node_local.append(np.asarray(local_pose, float).copy())
        self.node_global.append(compose(self.correction, local_pose))
        av = self.cfg.constraint_builder.loop_closure_adaptive_voxel_filter
        rows = hits if normals is None else np.column_stack([hits, normals])
        kept = adaptive_voxel_filter(rows, av.max_length, av.min_num_points, av.max_range, self.randomized_voxel_filter)
        self.node_points.append(np.ascontiguousarray(kept[:, :2]))
        self.node_normals.append(None if normals is None else kept[:, 2].copy())
        self.node_origins.append(np.zeros(2) if origin is None else np.asarray(origin, float)[:2].copy())
        self.node_submaps.append(tuple(inserted_into))
        if self.cfg.enable_loop_closure:
            self._search([(s, node) for s in self.builder.matchers if s not in inserted_into])
            for s in finished:
                self.builder.add_finished_submap(self.submaps[s])
                self._search([(s, n) for n in range(node + 1) if s not in self.node_submaps[n]])
        self._since_opt += 1
        if self.cfg.optimize_every_n_nodes > 0 and self._since_opt >= self.cfg.optimize_every_n_nodes:
            if len(self.loops) != self._loops_at_opt:
                self.optimize()
            else:
                # No new loop closure: the local constraints alone are already
                # satisfied by the corrected local poses, so the optimum would not move (ours:
                # saves the solve).
                self._since_opt = 0
        return node

    def finish_trajectory(self, unfinished: list[int]) -> None:
        """The route ended: every submap counts as finished and the graph is optimized a last
        time (Cartographer's FinishTrajectory). Ours: the submaps still unfinished (indices) are
        first searched against the older nodes for loop closures, as a newly finished submap
        is, so the route's last stretch gets closures from both sides like the rest."""
        if self.cfg.enable_loop_closure:
            for s in unfinished:
                if s in self.builder.matchers or s >= len(self.submap_global):
                    continue
                self.builder.add_finished_submap(self.submaps[s])
                self._search([(s, n) for n in range(len(self.node_local)) if s not in self.node_submaps[n]])
        self.optimize()

    def _search(self, pairs: list[tuple[int, int]]) -> None:
        """Search loop closures for (submap, node) pairs, in order."""
        if not pairs:
            return
        subs = [s for s, _ in pairs]
        sg = np.array([self.submap_global[s] for s in subs])
        ng = np.array([self.node_global[n] for _, n in pairs])
        for (s, n), chosen in zip(pairs, self.builder.sample(subs, sg, ng)):
            if chosen:
                c = self.builder.match(self.submaps[s], self.submap_global[s], n, self.node_global[n],
                                       self.node_points[n], self.node_origins[n], self.node_normals[n])
                if c is not None:
                    self.loops.append(c)

    def constraints(self) -> Constraints:
        """All constraints over the variables [submaps..., nodes...]."""
        ns = len(self.submap_global)
        nl = np.array(self.node_local).reshape(-1, 3)
        sub_local = np.array([self.submaps[k].local_pose for k in range(ns)]).reshape(-1, 3)
        counts = np.array([len(subs) for subs in self.node_submaps], int)
        intra_s = np.array([s for subs in self.node_submaps for s in subs], int)
        intra_n = np.repeat(np.arange(len(nl)), counts)
        op = self.cfg.optimization_problem
        cb = self.cfg.constraint_builder
        n_in, n_ch, n_lc = len(intra_s), max(len(nl) - 1, 0), len(self.loops)
        i = np.concatenate([intra_s, ns + np.arange(n_ch), np.array([c.submap for c in self.loops], int)])
        j = np.concatenate([ns + intra_n, ns + 1 + np.arange(n_ch), ns + np.array([c.node for c in self.loops], int)])
        z = np.vstack([relative(sub_local[intra_s], nl[intra_n]).reshape(-1, 3),
                       relative(nl[:-1], nl[1:]).reshape(-1, 3),
                       np.array([c.z for c in self.loops], float).reshape(-1, 3)])
        wt = np.concatenate([np.full(n_in, self.cfg.matcher_translation_weight),
                             np.full(n_ch, op.local_slam_pose_translation_weight),
                             np.full(n_lc, cb.loop_closure_translation_weight)])
        wr = np.concatenate([np.full(n_in, self.cfg.matcher_rotation_weight),
                             np.full(n_ch, op.local_slam_pose_rotation_weight),
                             np.full(n_lc, cb.loop_closure_rotation_weight)])
        rob = np.concatenate([np.zeros(n_in + n_ch, bool), np.ones(n_lc, bool)])
        # a loop closure that slides along a corridor weighs nothing along its slide axis
        slide = np.array([c.slide_axis is not None for c in self.loops], bool)
        axis = np.zeros(len(i))
        axis[n_in + n_ch:][slide] = [c.slide_axis for c in self.loops if c.slide_axis is not None]
        across = wt.copy()
        wt[n_in + n_ch:][slide] = 0.0
        return Constraints(i, j, z, wt, wr, rob, axis, across)

    def optimize(self) -> None:
        """Sparse pose adjustment over all submaps and nodes; the first submap holds the gauge."""
        self._since_opt = 0
        ns = len(self.submap_global)
        if ns == 0 or not self.node_local:
            return
        poses = np.vstack([np.array(self.submap_global), np.array(self.node_global)])
        fixed = np.zeros(len(poses), bool)
        fixed[0] = True
        op = self.cfg.optimization_problem
        for _ in range(2):
            out = optimize_poses(poses, self.constraints(), fixed, huber_scale=op.huber_scale,
                                 max_iterations=op.max_num_iterations)
            if op.max_loop_residual <= 0 or not self.loops:
                break
            # Ours: a loop closure the optimum still disagrees with by more than max_loop_residual
            # is taken for a false match, dropped, and the problem solved again.
            ls = np.array([c.submap for c in self.loops], int)
            ln = np.array([c.node for c in self.loops], int)
            lz = np.array([c.z for c in self.loops], float)
            err = _loop_errors(relative(out[ls], out[ns + ln]), lz, self.loops)
            bad = err > op.max_loop_residual
            if not bad.any():
                break
            self.rejected += int(bad.sum())
            self.loops = [c for c, b in zip(self.loops, bad) if not b]
            poses = out                       # warm start: the first optimum is close
        self.submap_global = [p for p in out[:ns]]
        self.node_global = [p for p in out[ns:]]
        last = ns - 1
        self.correction = compose(self.submap_global[last], inverse(self.submaps[last].local_pose))
        self.n_optimizations += 1
        self._loops_at_opt = len(self.loops)


def _loop_errors(found: np.ndarray, z: np.ndarray, loops: list[LoopConstraint]) -> np.ndarray:
    """(L,) m between the optimized relative poses `found` (L, 3) and the loop closures' z
    (L, 3), in the submap frame; a sliding closure counts only the part across its axis."""
    d = found[:, :2] - z[:, :2]
    err = np.hypot(d[:, 0], d[:, 1])
    for k, c in enumerate(loops):
        if c.slide_axis is not None:
            a = z[k, 2] + c.slide_axis
            err[k] = abs(-np.sin(a) * d[k, 0] + np.cos(a) * d[k, 1])
    return err
