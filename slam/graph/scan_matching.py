"""Scan matchers of the pose-graph SLAM, one per function (Hess et al. 2016, Sec. IV-C and V).

- real_time_correlative_match: exhaustive search over a small window around the prediction,
  scores weighted by a penalty on the distance from it (Cartographer's
  RealTimeCorrelativeScanMatcher2D); it also reports the yaw the scan alone prefers.
- ceres_match: least squares on the interpolated grid (CeresScanMatcher2D).
- FastCorrelativeMatcher: precomputation grids of one finished submap plus the
  branch-and-bound search over a large window (FastCorrelativeScanMatcher2D).

Grids: (rows, cols) probabilities, unknown = Cartographer's min probability, with meta
(5,) [ox, oy, resolution, rows, cols]; points: (N, 2) m in the robot frame; poses (3,).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam.graph._correlative_kernel import (bnb_margin, bnb_search, discretize_rotations, max_grids,
                                           score_candidates)
from slam.graph._match_kernel import match_lm, match_lm_directional
from slam.graph._tsdf_kernel import direction_mixes
from slam.graph.config import CeresScanMatcherConfig, FastCorrelativeConfig, RealTimeCorrelativeConfig
from slam.pose import transform_points

__all__ = ["range_weights", "angular_step", "discretize", "CorrelativeMatch", "real_time_correlative_match",
           "ceres_match", "submap_match", "FastCorrelativeMatcher"]


def angular_step(points: np.ndarray, resolution: float) -> float:
    """Rotation step (rad) that moves the farthest point by about one cell (Cartographer's
    SearchParameters: acos(1 - res^2 / (2 r_max^2)))."""
    r = float(np.max(np.hypot(points[:, 0], points[:, 1]))) if len(points) else 1.0
    r = max(r, resolution)
    return math.acos(max(-1.0, 1.0 - resolution ** 2 / (2.0 * r * r)))


def discretize(points: np.ndarray, pose: np.ndarray, yaws: np.ndarray, meta: np.ndarray) -> np.ndarray:
    """(K, N, 2) int32 (col, row) cells of the points at translation pose[:2] and each yaw (K,)."""
    return discretize_rotations(np.ascontiguousarray(points, dtype=np.float64), float(pose[0]), float(pose[1]),
                                np.ascontiguousarray(yaws, dtype=np.float64), float(meta[0]), float(meta[1]),
                                float(meta[2]))


def _window(points, meta, linear, angular, step=None):
    step = angular_step(points, meta[2]) if step is None else step
    n_ang = int(math.ceil(angular / step))
    wxy = int(math.ceil(linear / meta[2]))
    return step, n_ang, wxy


class CorrelativeMatch(NamedTuple):
    """real_time_correlative_match's answer."""

    pose: np.ndarray          # (3,) the best candidate with the distance penalty
    yaw_innovation: float     # rad, the best candidate's yaw offset from the prediction without it
    angular_step: float       # rad, the search's angular step


def real_time_correlative_match(prob: np.ndarray, meta: np.ndarray, points: np.ndarray,
                                pose: np.ndarray, cfg: RealTimeCorrelativeConfig,
                                rotation_delta_cost_weight: float | None = None) -> CorrelativeMatch:
    """The exhaustive search around `pose` (x, y m, yaw rad); rotation_delta_cost_weight
    replaces cfg's when given."""
    rw = cfg.rotation_delta_cost_weight if rotation_delta_cost_weight is None else rotation_delta_cost_weight
    step, n_ang, w = _window(points, meta, cfg.linear_search_window, cfg.angular_search_window)
    offsets = np.arange(-n_ang, n_ang + 1) * step
    cells = discretize(points, pose, pose[2] + offsets, meta)
    scores = score_candidates(prob, cells, w, w)
    res = meta[2]
    d = np.arange(-w, w + 1) * res
    dist = np.hypot(d[None, :, None], d[None, None, :])
    penalty = np.exp(-(dist * cfg.translation_delta_cost_weight + np.abs(offsets)[:, None, None] * rw) ** 2)
    k, a, b = np.unravel_index(int(np.argmax(scores * penalty)), scores.shape)
    k_free = np.unravel_index(int(np.argmax(scores)), scores.shape)[0]
    # The cell shift moves every point by whole cells: add it to the pose translation.
    return CorrelativeMatch(np.array([pose[0] + d[b], pose[1] + d[a], pose[2] + offsets[k]]),
                            float(offsets[k_free]), float(step))


def seen_weights(submap, points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(N,) least-squares weights of points (N, 2, robot frame) placed at `pose` (3,, the
    submap's local frame): 1 on cells `submap` has observed, 0 elsewhere (ours). A point on a
    never-observed cell reads the never-observed value, and the edge of the known map would
    pull it back: into the submap, for a node at the edge of an older one it is matched to."""
    return submap.known_at(transform_points(pose, points)).astype(np.float64)


def range_weights(points: np.ndarray, near_range: float) -> np.ndarray:
    """(N,) min(1, (near_range / range)^2): inverse range variance of the LDS-01, whose error
    grows in proportion to the range beyond ~0.5 m. near_range <= 0: all ones."""
    if near_range <= 0:
        return np.ones(len(points))
    r = np.hypot(points[:, 0], points[:, 1])
    return np.minimum(1.0, (near_range / np.maximum(r, 1e-6)) ** 2)


def _lm_args(points: np.ndarray, start: np.ndarray, prior: np.ndarray, cfg: CeresScanMatcherConfig,
             weights: np.ndarray | None) -> tuple:
    """The least squares' arguments after the grid: points, weights, start, and the target the
    pulls hold to (translation prior[:2], rotation start[2], as Cartographer's ceres matcher),
    then cfg's weights and iterations."""
    target = np.array([prior[0], prior[1], start[2]])
    w = np.ones(len(points)) if weights is None else np.asarray(weights, np.float64)
    return (np.ascontiguousarray(points, dtype=np.float64), w, np.asarray(start, np.float64), target,
            cfg.occupied_space_weight, cfg.translation_weight, cfg.rotation_weight, cfg.max_num_iterations)


def ceres_match(prob: np.ndarray, meta: np.ndarray, points: np.ndarray, start: np.ndarray,
                prior: np.ndarray, cfg: CeresScanMatcherConfig, weights: np.ndarray | None = None) -> np.ndarray:
    """Pose (3,) from least squares started at `start`; translation pulled toward prior[:2],
    rotation toward start[2] (as Cartographer's ceres matcher); weights: (N,) per point or None."""
    pose, _ = match_lm(prob, meta, *_lm_args(points, start, prior, cfg, weights))
    return pose


def submap_match(submap, points: np.ndarray, normals: np.ndarray | None, start: np.ndarray, prior: np.ndarray,
                 cfg: CeresScanMatcherConfig, weights: np.ndarray | None = None) -> np.ndarray:
    """ceres_match of points (N, 2, robot frame) against `submap`; on the directional layers of
    a TSDF submap that has them (slam.graph.tsdf) when the points' normals (N,) rad, robot frame,
    are given: each point reads the layers of its normal turned by start's yaw."""
    layers = submap.directional() if normals is not None else None
    if layers is None:
        prob, meta = submap.probabilities()
        return ceres_match(prob, meta, points, start, prior, cfg, weights)
    dir_tsd, dir_weight, truncation, meta = layers
    mix = direction_mixes(np.asarray(normals, np.float64) + float(start[2]), dir_tsd.shape[0])
    pose, _ = match_lm_directional(dir_tsd, dir_weight, float(truncation), mix, meta,
                                   *_lm_args(points, start, prior, cfg, weights))
    return pose


class FastCorrelativeMatcher:
    """Branch-and-bound matcher of one (finished) submap grid."""

    def __init__(self, prob: np.ndarray, meta: np.ndarray, cfg: FastCorrelativeConfig):
        self.cfg = cfg
        self.meta = np.asarray(meta, np.float64)
        depth = cfg.branch_and_bound_depth
        w = int(math.ceil(cfg.linear_search_window / self.meta[2]))
        self.margin = bnb_margin(depth, w, w)
        self.grids = max_grids(np.asarray(prob, np.float32), depth, self.margin)

    def search(self, points: np.ndarray, pose: np.ndarray, min_score: float, ambiguity_radius: float = 0.0,
               ambiguity_margin: float = 0.0, step: float | None = None
               ) -> tuple[np.ndarray, float, np.ndarray | None] | None:
        """Search around `pose` (3,) in the submap's frame: (best pose, score, other) or None
        when no pose scores above min_score.

        other (ours): with ambiguity_radius > 0 (m), the best pose farther than that from the
        best one that scores within ambiguity_margin of it (a corridor, a repeated room), else
        None. step: angular_step(points, resolution) when the caller has it (one node's points
        are matched against many submaps).
        """
        if len(points) == 0:
            return None
        step, n_ang, w = _window(points, self.meta, self.cfg.linear_search_window,
                                 self.cfg.angular_search_window, step)
        offsets = np.arange(-n_ang, n_ang + 1) * step
        cells = discretize(points, pose, pose[2] + offsets, self.meta)
        k, dx, dy, score = bnb_search(self.grids, self.margin, cells, w, w, float(min_score), 0, 0, -1)
        if k < 0:
            return None
        res = self.meta[2]
        other = None
        if ambiguity_radius > 0:
            r = int(math.ceil(ambiguity_radius / res))
            k2, dx2, dy2, _ = bnb_search(self.grids, self.margin, cells, w, w, float(score - ambiguity_margin),
                                         dx, dy, r)
            if k2 >= 0:
                other = np.array([pose[0] + dx2 * res, pose[1] + dy2 * res, pose[2] + offsets[k2]])
        return np.array([pose[0] + dx * res, pose[1] + dy * res, pose[2] + offsets[k]]), float(score), other
