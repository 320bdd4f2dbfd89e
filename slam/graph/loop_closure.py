"""Loop-closure constraint search (Cartographer's ConstraintBuilder2D, Hess et al. 2016 Sec. V).

For a node and a finished submap close enough to it, match the node's scan (loop-closure
adaptive voxel filter) against the submap with the fast correlative scan matcher around the
current relative pose estimate; a match scoring above min_score is refined by least squares
on the submap grid (the constraint builder's own ceres_scan_matcher options) and becomes a
loop-closure constraint with the loop_closure weights. Which pairs are tried is decided per
submap by a fixed-ratio sampler, as Cartographer's FixedRatioSampler (deterministic).
Ours: a match whose translation is pinned in one direction only constrains only what it
pins. That is a match whose information ratio is below min_information_ratio (a straight
corridor, where any shift along it scores the same), or one with an ambiguity (another pose
farther than ambiguity_radius scoring within ambiguity_margin) that lies along the match's
weakest direction: its position along the corridor is a guess, its side position and heading
are not, so its constraint weighs nothing along that direction (a lidar that looks forward
down a corridor closes loops there only this way). An ambiguity in any other direction (a
repeated room or shelf) rejects the match, as does a match through which the scan would see
into space the submap knows to be free (see_through_ratio: the far faces of thin walls,
mapped from their other side).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam._kernels.interp import interp_value_grad
from slam.pose import compose, relative, transform_points
from slam.graph.config import ConstraintBuilderConfig
from slam.graph.scan_matching import FastCorrelativeMatcher, angular_step, seen_weights, submap_match
from slam.graph.submaps import Submap

__all__ = ["FixedRatioSampler", "LoopConstraint", "ConstraintBuilder", "translation_information",
           "see_through_ratio"]

# An ambiguity counts as a slide along the weak direction when it lies within this angle of it
# and the weak direction's information is at most this share of the strong one's; otherwise
# it is a repeat (a second door, a second shelf), not a corridor.
_SLIDE_ANGLE = np.radians(10.0)
_SLIDE_MAX_RATIO = 0.3


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
    """Node `node` seen from submap `submap` at z (3,) (submap frame), with the match score;
    slide_axis: for a match pinned across one direction only, that direction (rad from z's x
    axis), along which the constraint weighs nothing; None: pinned in both."""

    submap: int
    node: int
    z: np.ndarray
    score: float
    slide_axis: float | None = None


class ConstraintBuilder:
    """Finds loop-closure constraints between nodes and finished submaps."""

    def __init__(self, cfg: ConstraintBuilderConfig):
        self.cfg = cfg
        self.matchers: dict[int, FastCorrelativeMatcher] = {}
        self.samplers: dict[int, FixedRatioSampler] = {}
        self.attempts = 0
        self.sliding = 0          # matches kept as slides along a corridor
        self.ambiguous = 0        # matches rejected for an ambiguity across their weak direction
        self.see_through = 0
        self._step = (None, 0.0, 0.0)     # (points, resolution, angular step) of the last node matched

    def add_finished_submap(self, submap: Submap) -> None:
        """Precompute the branch-and-bound grids of a submap that gets no more scans."""
        prob, meta = submap.search_grid()
        self.matchers[submap.index] = FastCorrelativeMatcher(prob, meta,
                                                             self.cfg.fast_correlative_scan_matcher)
        self.samplers[submap.index] = FixedRatioSampler(self.cfg.sampling_ratio)

    def compute(self, submap: Submap, submap_global: np.ndarray, node: int, node_global: np.ndarray,
                points: np.ndarray, origin: np.ndarray, normals: np.ndarray | None = None) -> LoopConstraint | None:
        """Try one (finished submap, node) pair; points (N, 2) robot frame, filtered, seen from
        the lidar at origin (2,) robot frame, with their normal angles (N,) rad or None."""
        if not self.sample([submap.index], submap_global[None, :], node_global[None, :])[0]:
            return None
        return self.match(submap, submap_global, node, node_global, points, origin, normals)

    def sample(self, submaps: list, submap_global: np.ndarray, node_global: np.ndarray) -> list:
        """Which of the (submap, node) pairs, in order, to match: (M,) bool of the submap
        indices (M,) and the poses (M, 3) of the submaps and the nodes. A pair farther apart
        than max_constraint_distance is not; the others pulse their submap's sampler."""
        d = np.hypot(node_global[:, 0] - submap_global[:, 0], node_global[:, 1] - submap_global[:, 1])
        far = d > self.cfg.max_constraint_distance
        return [not f and self.samplers[s].pulse() for s, f in zip(submaps, far)]

    def match(self, submap: Submap, submap_global: np.ndarray, node: int, node_global: np.ndarray,
              points: np.ndarray, origin: np.ndarray, normals: np.ndarray | None = None) -> LoopConstraint | None:
        """compute() of a pair that sample() chose."""
        self.attempts += 1
        # Initial guess: the node in the submap's local grid frame via the global poses.
        initial = compose(submap.local_pose, relative(submap_global, node_global))
        matcher = self.matchers[submap.index]
        res = matcher.meta[2]
        if self._step[0] is not points or self._step[1] != res:
            self._step = (points, res, angular_step(points, res))
        found = matcher.search(points, initial, self.cfg.min_score, self.cfg.ambiguity_radius,
                               self.cfg.ambiguity_margin, self._step[2])
        if found is None:
            return None
        pose, score, other = found
        prob, meta = submap.probabilities()
        refined = submap_match(submap, points, normals, pose, pose, self.cfg.ceres_scan_matcher,
                               seen_weights(submap, points, pose))
        ev, vec = np.linalg.eigh(translation_information(prob, meta, points, refined))
        weak = vec[:, 0]
        slides = self.cfg.min_information_ratio > 0 and ev[0] < self.cfg.min_information_ratio * ev[1]
        if other is not None:
            shift = other[:2] - pose[:2]
            along = abs(shift @ weak) >= np.cos(_SLIDE_ANGLE) * np.hypot(*shift)
            if not along or other[2] != pose[2] or ev[0] > _SLIDE_MAX_RATIO * ev[1]:
                self.ambiguous += 1
                return None
            slides = True
        if slides:
            # Along the slide the search's pose is a guess that may lie far down the corridor,
            # where a door or a corner would tilt the refined heading: refine again from the
            # current estimate's place along it and the search's place across it.
            across = np.array([-weak[1], weak[0]])
            start = np.array([*(initial[:2] + ((pose[:2] - initial[:2]) @ across) * across), pose[2]])
            refined = submap_match(submap, points, normals, start, start, self.cfg.ceres_scan_matcher,
                                   seen_weights(submap, points, start))
        if self.cfg.max_see_through_ratio > 0:
            ratio = see_through_ratio(submap, points, origin, refined, self.cfg.see_through_free_probability)
            if ratio > self.cfg.max_see_through_ratio:
                self.see_through += 1
                return None
        # weak is in the submap's grid frame; the constraint's axes turn with the node (z's yaw)
        axis = float(np.arctan2(weak[1], weak[0]) - refined[2]) if slides else None
        self.sliding += slides
        return LoopConstraint(submap.index, node, relative(submap.local_pose, refined), score, axis)


def translation_information(prob: np.ndarray, meta: np.ndarray, points: np.ndarray,
                            pose: np.ndarray) -> np.ndarray:
    """(2, 2) translation information sum(grad M grad M^T) of the points (N, 2, robot frame)
    at `pose` on the grid (grid frame)."""
    g = interp_value_grad(prob, meta, np.ascontiguousarray(transform_points(pose, points)))
    return g[:, 1:].T @ g[:, 1:]


def see_through_ratio(submap: Submap, points: np.ndarray, origin: np.ndarray, pose: np.ndarray,
                      free_probability: float) -> float:
    """Fraction of the points (N, 2, robot frame, seen from the lidar at origin (2,)) whose cell
    one submap cell beyond them along the beam is known free (observed, probability below
    free_probability) in `submap` with the robot at `pose` (3,, local frame).

    Behind a surface the lidar hit lies the inside of a wall or space nobody saw; space seen
    free there means the scan is placed on the far face of a thin wall whose other side the
    submap saw (a hit-only match score rates both faces alike).
    """
    d = np.asarray(points, float) - np.asarray(origin, float)[None, :]
    r = np.hypot(d[:, 0], d[:, 1])
    keep = r > 1e-9
    if not keep.any():
        return 0.0
    beyond = points[keep] + d[keep] / r[keep, None] * submap.grid.resolution
    p = submap.probability_at(transform_points(pose, beyond))
    return float(np.mean(p < free_probability))         # NaN (unknown) compares False
