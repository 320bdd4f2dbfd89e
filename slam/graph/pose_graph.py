"""Global SLAM: nodes, submaps and constraints, optimized by sparse pose adjustment.

As Cartographer's PoseGraph2D: each node gets an intra-submap constraint to every submap it
was inserted into (its local-SLAM pose in that submap, matcher weights); consecutive nodes are
tied by their local-SLAM relative pose (local_slam_pose weights); loop-closure constraints
come from the ConstraintBuilder (new node vs finished submaps, and a newly finished submap vs
older nodes). Every optimize_every_n_nodes nodes, and at the end, all poses are optimized;
the local-to-global correction is then the one of the newest submap.
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

    def __init__(self, cfg: GlobalConfig, submaps: list[Submap]):
        self.cfg = cfg
        self.submaps = submaps                      # shared with the local SLAM's ActiveSubmaps
        self.submap_global: list[np.ndarray] = []
        self.node_local: list[np.ndarray] = []
        self.node_global: list[np.ndarray] = []
        self.node_points: list[np.ndarray] = []     # loop-closure filtered, robot frame
        self.node_submaps: list[tuple] = []
        self.loops: list[LoopConstraint] = []
        self.builder = ConstraintBuilder(cfg.constraint_builder)
        self.correction = np.zeros(3)               # local -> global
        self.n_optimizations = 0
        self.rejected = 0
        self._since_opt = 0
        self._loops_at_opt = 0

    def add_node(self, local_pose: np.ndarray, hits: np.ndarray, inserted_into: tuple,
                 created: tuple, finished: tuple) -> int:
        """Add a node (local pose (3,), hits (N, 2) robot frame); search loops; maybe optimize."""
        for s in created:
            while len(self.submap_global) <= s:
                self.submap_global.append(compose(self.correction, self.submaps[len(self.submap_global)].local_pose))
        node = len(self.node_local)
        self.node_local.append(np.asarray(local_pose, float).copy())
        self.node_global.append(compose(self.correction, local_pose))
        av = self.cfg.constraint_builder.loop_closure_adaptive_voxel_filter
        self.node_points.append(adaptive_voxel_filter(hits, av.max_length, av.min_num_points, av.max_range))
        self.node_submaps.append(tuple(inserted_into))
        if self.cfg.enable_loop_closure:
            for s in self.builder.matchers:
                if s not in inserted_into:
                    self._try(s, node)
            for s in finished:
                self.builder.add_finished_submap(self.submaps[s])
                for n in range(node + 1):
                    if s not in self.node_submaps[n]:
                        self._try(s, n)
        self._since_opt += 1
        if self.cfg.optimize_every_n_nodes > 0 and self._since_opt >= self.cfg.optimize_every_n_nodes:
            if len(self.loops) != self._loops_at_opt:
                self.optimize()
            else:
                # No new loop closure: the local constraints alone are already satisfied by the
                # corrected local poses, so the optimum would not move (ours: saves the solve).
                self._since_opt = 0
        return node

    def _try(self, s: int, n: int) -> None:
        c = self.builder.compute(self.submaps[s], self.submap_global[s], n, self.node_global[n],
                                 self.node_points[n])
        if c is not None:
            self.loops.append(c)

    def constraints(self) -> Constraints:
        """All constraints over the variables [submaps..., nodes...]."""
        ns = len(self.submap_global)
        i, j, z, wt, wr, rob = [], [], [], [], [], []
        for n, subs in enumerate(self.node_submaps):
            for s in subs:
                i.append(s); j.append(ns + n)
                z.append(relative(self.submaps[s].local_pose, self.node_local[n]))
                wt.append(self.cfg.matcher_translation_weight); wr.append(self.cfg.matcher_rotation_weight)
                rob.append(False)
        op = self.cfg.optimization_problem
        for n in range(1, len(self.node_local)):
            i.append(ns + n - 1); j.append(ns + n)
            z.append(relative(self.node_local[n - 1], self.node_local[n]))
            wt.append(op.local_slam_pose_translation_weight); wr.append(op.local_slam_pose_rotation_weight)
            rob.append(False)
        cb = self.cfg.constraint_builder
        for c in self.loops:
            i.append(c.submap); j.append(ns + c.node); z.append(c.z)
            wt.append(cb.loop_closure_translation_weight); wr.append(cb.loop_closure_rotation_weight)
            rob.append(True)
        return Constraints(np.array(i, int), np.array(j, int), np.array(z, float).reshape(-1, 3),
                           np.array(wt, float), np.array(wr, float), np.array(rob, bool))

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
                                 max_iterations=op.max_num_iterations, solver=op.solver)
            if op.max_loop_residual <= 0 or not self.loops:
                break
            # Ours: a loop closure the optimum still disagrees with by more than max_loop_residual
            # is taken for a false match, dropped, and the problem solved again.
            err = np.array([np.hypot(*(relative(out[c.submap], out[ns + c.node])[:2] - c.z[:2]))
                            for c in self.loops])
            bad = err > op.max_loop_residual
            if not bad.any():
                break
            self.rejected += int(bad.sum())
            self.loops = [c for c, b in zip(self.loops, bad) if not b]
        self.submap_global = [p for p in out[:ns]]
        self.node_global = [p for p in out[ns:]]
        last = ns - 1
        self.correction = compose(self.submap_global[last], inverse(self.submaps[last].local_pose))
        self.n_optimizations += 1
        self._loops_at_opt = len(self.loops)
