"""Hector's coarse-to-fine Gauss-Newton scan matching on the multi-resolution map
(minimise sum_i (1 - M(S_i(xi)))^2 over the scan end points; slam/_kernels/gauss_newton.py)."""
from __future__ import annotations

import numpy as np

from slam._kernels.gauss_newton import NO_NORMALS, gn_iterate

__all__ = ["match_scan"]

_NO_PRIOR = np.zeros((3, 3))


def _gauss_newton(prob, meta, pts, est, n_it, max_angle_step, prior, prior_info, normals):
    """n_it Gauss-Newton steps on one level; returns (pose, cost at the returned pose)."""
    return gn_iterate(prob, meta, pts, np.asarray(est, dtype=np.float64), int(n_it),
                      float(max_angle_step), prior, prior_info, normals)


def match_scan(levels: list[tuple[np.ndarray, np.ndarray]], points: np.ndarray, pose: np.ndarray,
               iterations: list[int], max_angle_step: float = 0.2, check_prior: bool = True,
               prior: np.ndarray | None = None, prior_info: np.ndarray | None = None,
               normals: np.ndarray | None = None) -> np.ndarray:
    """The refined (3,) pose of a scan.

    levels: [(prob (rows, cols), grid_meta (5,))] finest first; points: (N, 2) m in the robot
    frame; pose: (3,) initial world pose; iterations: steps per level, finest first.
    check_prior: also run the finest level from `pose` itself and keep whichever end has the
    lower cost (a coarse level can be biased by up to half its cell, out of the finest
    level's reach). prior: (3,) motion prior pose (None: `pose`); prior_info: its (3, 3)
    information matrix (None: no prior). normals: (N, 2) robot-frame surface normals, each
    point's map gradient read along its normal (zero row: the full gradient; None: stock Hector).
    """
    est = np.array(pose, dtype=np.float64)
    pts = np.ascontiguousarray(points, dtype=np.float64)
    nrm = NO_NORMALS if normals is None else np.ascontiguousarray(normals, dtype=np.float64)
    prior = est.copy() if prior is None else np.asarray(prior, dtype=np.float64)
    info = _NO_PRIOR if prior_info is None else np.ascontiguousarray(prior_info, dtype=np.float64)
    for (prob, meta), n_it in list(zip(levels, iterations))[:0:-1]:
        est, _ = _gauss_newton(prob, meta, pts, est, n_it, max_angle_step, prior, info, nrm)
    prob, meta = levels[0]
    est, cost = _gauss_newton(prob, meta, pts, est, iterations[0], max_angle_step, prior, info, nrm)
    if check_prior and len(levels) > 1:
        alt, alt_cost = _gauss_newton(prob, meta, pts, np.array(pose, dtype=np.float64),
                                      iterations[0], max_angle_step, prior, info, nrm)
        if cost >= alt_cost:
            est = alt
    return est
