"""Loop-closure constraint search (Cartographer's ConstraintBuilder2D, Hess et al. 2016 Sec. V).

For a node and a finished submap close enough to it, match the node's scan (loop-closure
adaptive voxel filter) against the submap with the fast correlative scan matcher around the
current relative pose estimate; a match scoring above min_score is refined by least squares
on the submap grid (the constraint builder's own ceres_scan_matcher options) and becomes a
loop-closure constraint with the loop_closure weights. Which pairs are tried is decided per
submap by a fixed-ratio sampler, as Cartographer's FixedRatioSampler (deterministic).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam.pose import compose, inverse, relative
from slam.graph.config import ConstraintBuilderConfig
from slam.graph.scan_matching import FastCorrelativeMatcher, ceres_match
from slam.graph.submaps import Submap

__all__ = ["FixedRatioSampler", "LoopConstraint", "ConstraintBuilder"]


class FixedRatioSampler:
    """Pulse i is sampled when samples so far / pulses so far < ratio (deterministic)."""

    def __init__(self, ratio: float):
        self.ratio = float(ratio)
        self.pulses = 0
        self.samples = 0

    def pulse(self) -> bool:
        self.pulses += 1
        if self.samples / self.pulses < self.ratio:
            self.samples += 1
            return True
        return False


@dataclass(frozen=True)
class LoopConstraint:
    """Node `node` seen from submap `submap` at z (3,) (submap frame), with the match score."""

    submap: int
    node: int
    z: np.ndarray
    score: float


class ConstraintBuilder:
    """Finds loop-closure constraints between nodes and finished submaps."""

    def __init__(self, cfg: ConstraintBuilderConfig):
        self.cfg = cfg
        self.matchers: dict[int, FastCorrelativeMatcher] = {}
        self.samplers: dict[int, FixedRatioSampler] = {}
        self.attempts = 0

    def add_finished_submap(self, submap: Submap) -> None:
        """Precompute the branch-and-bound grids of a submap that gets no more scans."""
        prob, meta = submap.probabilities()
        self.matchers[submap.index] = FastCorrelativeMatcher(prob, meta,
                                                             self.cfg.fast_correlative_scan_matcher)
        self.samplers[submap.index] = FixedRatioSampler(self.cfg.sampling_ratio)

    def compute(self, submap: Submap, submap_global: np.ndarray, node: int, node_global: np.ndarray,
                points: np.ndarray) -> LoopConstraint | None:
        """Try one (finished submap, node) pair; points (N, 2) robot frame, filtered."""
        if np.hypot(*(node_global[:2] - submap_global[:2])) > self.cfg.max_constraint_distance:
            return None
        if not self.samplers[submap.index].pulse():
            return None
        self.attempts += 1
        # Initial guess: the node in the submap's local grid frame via the global poses.
        initial = compose(submap.local_pose, relative(submap_global, node_global))
        found = self.matchers[submap.index].match(points, initial, self.cfg.min_score)
        if found is None:
            return None
        pose, score = found
        prob, meta = submap.probabilities()
        refined = ceres_match(prob, meta, points, pose, pose, self.cfg.ceres_scan_matcher)
        return LoopConstraint(submap.index, node, relative(submap.local_pose, refined), score)
