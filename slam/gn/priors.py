"""The quadratic priors every Gauss-Newton step of gn is pulled by (none is in hector):
the gyro's yaw, the constant-velocity position and, along a direction the scan's surface
normals leave unconstrained (degeneracy-aware matching, Zhang, Kaess, Singh, ICRA 2016), the
constant-velocity position held hard."""
from __future__ import annotations

import math

import numpy as np

from slam.gn._normals_kernel import normal_information, scan_normals
from slam.gn.config import GnConfig

__all__ = ["NORMAL_HALF_WINDOW", "NORMAL_MAX_GAP", "surface_normals", "degenerate_direction",
           "motion_prior"]

# scan normals: 2 beams to either side (5 points, about 5 degrees of the LDS-01), neighbours
# at most 0.2 m per beam step away (farther ones are across an edge)
NORMAL_HALF_WINDOW = 2
NORMAL_MAX_GAP = 0.2


def surface_normals(cfg: GnConfig, points: np.ndarray) -> np.ndarray | None:
    """(N, 2) scan normals of the points (N, 2), or None when neither the gradient projection
    nor the degeneracy check needs them (stock hector)."""
    if cfg.gradient_along_normal or cfg.degeneracy_threshold > 0:
        return scan_normals(points, NORMAL_HALF_WINDOW, NORMAL_MAX_GAP)
    return None


def degenerate_direction(cfg: GnConfig, normals: np.ndarray | None, observed: np.ndarray | None,
                         pose: np.ndarray) -> np.ndarray | None:
    """World-frame unit direction of translation the scan's normals do not constrain (the
    smaller eigenvector of their mean outer product, if its eigenvalue is below
    degeneracy_threshold), else None. observed: (N,) bool (None when the check is off), the
    points lie on mapped ground; the others count as points without a normal (a wall coming
    into view is not in the map until the next map update)."""
    if cfg.degeneracy_threshold <= 0 or normals is None:
        return None
    lam, vec = np.linalg.eigh(normal_information(normals * observed[:, None]))
    if lam[0] >= cfg.degeneracy_threshold:
        return None
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([c * vec[0, 0] - s * vec[1, 0], s * vec[0, 0] + c * vec[1, 0]])


def motion_prior(cfg: GnConfig, predicted: np.ndarray, moved_xy: np.ndarray, n_points: int,
                 has_gyro: bool, has_history: bool,
                 degenerate: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(prior pose (3,), information (3, 3)) of the match: the yaw pulled to the gyro's
    prediction, the position to the constant-velocity one (with velocity_prior_weight, or
    hard along a degenerate direction, the other direction then left to the map)."""
    prior, info = predicted.copy(), np.zeros((3, 3))
    if has_gyro:
        info[2, 2] = cfg.prior_yaw_weight * n_points
    if cfg.velocity_prior_weight > 0 and has_history:
        prior[:2] = moved_xy
        info[:2, :2] = cfg.velocity_prior_weight * n_points * np.eye(2)
    if degenerate is not None:
        prior[:2] = moved_xy
        info[:2, :2] = cfg.degeneracy_weight * n_points * np.outer(degenerate, degenerate)
    return prior, info
