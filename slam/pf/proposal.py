"""The improved proposal of the particle filter (Grisetti, Stachniss, Burgard 2007, Sec. IV):
per particle, scan matching on its own map (Gmapping's hill climb, then Gauss-Newton steps on
the point-to-line distances to the walls of its mean hit points), a Gaussian around the matched
pose (mean and normaliser eta from likelihood x motion prior on a small grid, covariance the
inverse of the refinement's information), the new pose drawn from it and the weight
multiplied by eta."""
from __future__ import annotations

import numpy as np

from slam.pf._proposal_kernel import box_patch, propose_particles
from slam.pf._refine_kernel import line_iterate
from slam.pf.config import PfConfig
from slam.pf.maps import TiledMaps
from slam.pose import wrap_angle

__all__ = ["refine_pose", "propose", "MATCH_ROOM"]

# m around the scan's end points read from a particle's map: the matcher's moves from the
# proposal's start stay far inside it
MATCH_ROOM = 0.5


def refine_pose(maps: TiledMaps, p: int, box: np.ndarray, hits: np.ndarray, frees: np.ndarray,
                pose: np.ndarray, params: np.ndarray, iterations: int, max_angle_step: float,
                prior: np.ndarray, prior_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The proposal's Gauss-Newton steps on particle p's map (slam/pf/_refine_kernel.py).

    box: (4,) the cells read (first row, column, rows, columns); hits, frees: (K, 2) scan end
    points and their free points, robot frame, m; pose: (3,) start; params: the matcher's
    (fullness and kernel are read); prior (3,), prior_w (3,): the quadratic pull towards the
    motion prior (weights per m^2, m^2, rad^2). Returns the refined (3,) pose and its (3, 3)
    information, prior included.
    """
    prob, count, mean_off, meta = box_patch(maps.tables[p], maps.pool, maps.grid_meta,
                                            np.asarray(box, dtype=np.int64))
    return line_iterate(prob, count, mean_off, meta, float(params[3]), int(params[4]),
                        np.ascontiguousarray(hits, dtype=np.float64),
                        np.ascontiguousarray(frees, dtype=np.float64),
                        np.asarray(pose, dtype=np.float64), int(iterations),
                        float(max_angle_step), np.asarray(prior, dtype=np.float64),
                        np.diag(np.asarray(prior_w, dtype=np.float64)))


def propose(cfg: PfConfig, maps: TiledMaps, poses: np.ndarray, prior_mean: np.ndarray,
            prior_std: np.ndarray, hits: np.ndarray, frees: np.ndarray, params: np.ndarray,
            rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(new poses (N, 3), log eta (N,)) of particles at poses (N, 3) with motion prior means
    (N, 3) and standard deviations (3,), for the scan's hit points (K, 2) and their free
    points (K, 2) one cell closer to the lidar (robot frame): each particle matched on its
    own map, refined, and its pose drawn from the Gaussian fitted around the result."""
    m = cfg.matcher
    # per particle, a dense patch of its map: the bounding box of the scan's end points at its
    # pose plus room for the matcher's moves, clipped to the tiles the particle has written
    # (half bounds the patch's buffers: the reach of the farthest end point plus that room)
    reach = float(np.max(np.linalg.norm(hits, axis=1))) if len(hits) else 0.0
    half = int(np.ceil((reach + MATCH_ROOM) / cfg.delta))
    room = int(np.ceil(MATCH_ROOM / cfg.delta))
    prior_w = m.gn_prior_weight / prior_std ** 2   # the prior as Gauss-Newton weights
    mean, cov, log_eta = propose_particles(
        maps.tables, maps.pool, maps.grid_meta, np.ascontiguousarray(poses, dtype=np.float64),
        np.ascontiguousarray(prior_mean, dtype=np.float64),
        np.ascontiguousarray(prior_std, dtype=np.float64), hits, frees, params, half, room,
        int(m.gn_iterations), float(m.gn_max_angle_step), prior_w, float(m.minimum_score))
    # a tiny jitter keeps the Cholesky factor defined when the grid likelihood is one-peaked
    chol = np.linalg.cholesky(cov + np.diag([1e-8, 1e-8, 1e-8]))
    z = rng.standard_normal((len(poses), 3))
    new = mean + np.einsum("nij,nj->ni", chol, z)
    new[:, 2] = wrap_angle(new[:, 2])
    return new, log_eta
