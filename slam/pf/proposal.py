"""The improved proposal of the particle filter (Grisetti, Stachniss, Burgard 2007, Sec. IV):
per particle, scan matching on its own map (Gmapping's hill climb, then Gauss-Newton steps on
the map read as a reflectance map), a Gaussian fitted to likelihood x motion prior on a small
grid around the matched pose, the new pose drawn from it and the weight multiplied by its
normaliser eta."""
from __future__ import annotations

import numpy as np

from slam.pf._match_kernel import extract_patches, hill_climb, proposal_moments
from slam.pf._refine_kernel import mean_hit_iterate, mean_hit_patch
from slam.pf.config import PfConfig
from slam.pf.maps import TiledMaps
from slam.pose import wrap_angle

__all__ = ["refine_pose", "patch_box", "propose"]


def refine_pose(maps: TiledMaps, p: int, box: np.ndarray, points: np.ndarray, pose: np.ndarray,
                iterations: int, max_angle_step: float, prior: np.ndarray,
                prior_w: np.ndarray) -> np.ndarray:
    """Hector's Gauss-Newton steps on particle p's count map read as a reflectance map with
    each cell's ridge at its mean hit point (slam/pf/_refine_kernel.py).

    box: (4,) the cells read (first row, column, rows, columns); points: (K, 2) scan end
    points, robot frame, m; pose: (3,) start; prior (3,), prior_w (3,): the quadratic pull
    towards the motion prior (weights per m^2, m^2, rad^2). Returns the refined (3,) pose.
    """
    meta = maps.grid_meta
    res = meta[2]
    corner = (meta[0] + box[1] * res, meta[1] + box[0] * res)
    prob, off_x, off_y, hits = mean_hit_patch(maps.tables[p], maps.pool, meta, box)
    patch_meta = np.array([*corner, res, *prob.shape], dtype=np.float64)
    pts = np.ascontiguousarray(points, dtype=np.float64)
    prior_info = np.diag(np.asarray(prior_w, dtype=np.float64))
    return mean_hit_iterate(prob, off_x, off_y, hits, patch_meta, pts,
                            np.asarray(pose, dtype=np.float64), int(iterations),
                            float(max_angle_step), np.asarray(prior, dtype=np.float64), prior_info)


def patch_box(maps: TiledMaps, p: int, pose: np.ndarray, half: int) -> np.ndarray:
    """(1, 4) first row, column, rows, columns of particle p's patch: `half` cells around its
    pose (3,), clipped to the tiles it has written."""
    meta, t = maps.grid_meta, maps.tile
    r = int(np.floor((pose[1] - meta[1]) / meta[2]))
    col = int(np.floor((pose[0] - meta[0]) / meta[2]))
    r0, r1, c0, c1 = r - half, r + half, col - half, col + half
    a, b = np.nonzero(maps.tables[p] >= 0)
    if len(a):
        r0, r1 = max(r0, a.min() * t), min(r1, (a.max() + 1) * t)
        c0, c1 = max(c0, b.min() * t), min(c1, (b.max() + 1) * t)
    return np.array([[r0, c0, max(r1 - r0, 0), max(c1 - c0, 0)]], dtype=np.int64)


def propose(cfg: PfConfig, maps: TiledMaps, poses: np.ndarray, prior_mean: np.ndarray,
            prior_std: np.ndarray, hits: np.ndarray, frees: np.ndarray, params: np.ndarray,
            rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(new poses (N, 3), log eta (N,)) of particles at poses (N, 3) with motion prior means
    (N, 3) and standard deviations (3,), for the scan's hit points (K, 2) and their free
    points (K, 2) one cell closer to the lidar (robot frame)."""
    m = cfg.matcher
    # per particle, a dense patch of its map: the reach of the farthest beam end plus room
    # for the matcher's moves, clipped to the tiles the particle has written
    reach = float(np.max(np.linalg.norm(hits, axis=1))) if len(hits) else 0.0
    half = int(np.ceil((reach + 0.5) / cfg.delta))
    prior_w = m.gn_prior_weight / prior_std ** 2   # the prior as Gauss-Newton weights
    n = len(poses)
    start, mean, cov, log_eta = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3, 3)), np.empty(n)
    for p in range(n):
        box = patch_box(maps, p, poses[p], half)
        occ, mean_xy, corner = extract_patches(maps.tables[p:p + 1], maps.pool, maps.grid_meta,
                                               box, m.fullness)
        patch = (occ, mean_xy, corner, maps.grid_meta)
        matched, score = hill_climb(*patch, poses[p:p + 1], hits, frees, params)
        start[p] = matched[0] if score[0] > m.minimum_score else poses[p]
        if m.gn_iterations > 0 and score[0] > m.minimum_score:
            start[p] = refine_pose(maps, p, box[0], hits, start[p], m.gn_iterations,
                                   m.gn_max_angle_step, prior_mean[p], prior_w)
        mu, cv, le = proposal_moments(*patch, start[p:p + 1], prior_mean[p:p + 1],
                                      prior_std[None, :], hits, frees, params)
        mean[p], cov[p], log_eta[p] = mu[0], cv[0], le[0]
    # a tiny jitter keeps the Cholesky factor defined when the grid likelihood is one-peaked
    chol = np.linalg.cholesky(cov + np.diag([1e-8, 1e-8, 1e-8]))
    z = rng.standard_normal((n, 3))
    new = mean + np.einsum("nij,nj->ni", chol, z)
    new[:, 2] = wrap_angle(new[:, 2])
    return new, log_eta
