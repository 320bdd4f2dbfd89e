"""The improved proposal of every particle in one compiled loop (see slam/pf/proposal.py): per
particle, its map patch around its pose is read once; Gmapping's hill climb on it, the
Gauss-Newton refinement from there when the match is good enough, then the proposal's
moments around the result: its mean and weight from Gmapping's sampled likelihood, its
covariance the inverse of the refinement's information (the Laplace approximation; the sampled
covariance where the refinement did not run or its information is singular).

propose_particles: compiled; propose_particles_ref: the same loop in Python over the
single-particle kernels, for tests (box_patch: a patch in arrays of its own).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from slam.pf._map_kernel import narrow_box, patch_box, read_patch
from slam.pf._match_kernel import hill_climb, proposal_moments
from slam.pf._refine_kernel import line_iterate

__all__ = ["propose_particles", "propose_particles_ref", "box_patch"]


@njit(cache=True, nogil=True)
def _patch_meta(grid_meta, box):
    """[ox, oy, resolution, rows, columns] of the patch over box in the grid of grid_meta."""
    res = grid_meta[2]
    return np.array([grid_meta[0] + box[1] * res, grid_meta[1] + box[0] * res, res, box[2],
                     box[3]], dtype=np.float64)


@njit(cache=True, nogil=True)
def _patch(tables, pool, grid_meta, p, pose, half, points, room, box, inner, prob, hits,
           mean_off):
    """Particle p's patch around pose, read within `room` of the scan's end points (K, 2)
    there: views of the filled part of the buffers, the corner (row, column) and the patch's
    own [ox, oy, resolution, rows, columns]. The patch keeps the frame of the whole box, so
    the matcher's arithmetic is the same whichever part of it is read."""
    patch_box(tables[p], grid_meta, pose, half, box)
    for a in range(4):  # element writes: a slice copy compiles numba's shape-error message (3 s)
        inner[a] = box[a]
    narrow_box(grid_meta, pose, points, room, inner)
    read_patch(tables[p], pool, grid_meta, box, inner, prob, hits, mean_off)
    nr, nc = box[2], box[3]
    return (prob[:nr, :nc], hits[:nr, :nc], mean_off[:nr, :nc], box[:2].copy(),
            _patch_meta(grid_meta, box))


@njit(cache=True, nogil=True)
def propose_particles(tables, pool, grid_meta, poses, prior_mean, prior_std, hits, frees, params,
                      half, room, gn_iterations, gn_max_angle_step, gn_prior_w, minimum_score):
    """Per particle p (tables (N, TR, TC) into pool, poses (N, 3), motion prior means
    prior_mean (N, 3) and standard deviations prior_std (3,)), matching on the cells within
    `half` of its pose and within `room` of the bounding box of the scan's end points placed
    there: the proposal's mean (N, 3), covariance (N, 3, 3) and log eta (N,).
    hits, frees: (K, 2) robot frame; gn_prior_w (3,): the Gauss-Newton pull towards the
    prior mean (weights per m^2, m^2, rad^2)."""
    n = poses.shape[0]
    means = np.empty((n, 3))
    covs = np.empty((n, 3, 3))
    log_eta = np.empty(n)
    prior_info = np.diag(gn_prior_w)
    box = np.empty(4, dtype=np.int64)
    inner = np.empty(4, dtype=np.int64)
    prob = np.empty((2 * half, 2 * half), dtype=np.float32)
    hit_count = np.empty((2 * half, 2 * half), dtype=np.float32)
    mean_off = np.empty((2 * half, 2 * half, 2), dtype=np.float32)
    for p in range(n):
        pr, hc, mo, corner, meta = _patch(tables, pool, grid_meta, p, poses[p], half, hits, room,
                                          box, inner, prob, hit_count, mean_off)
        start, score = hill_climb(pr, mo, corner, grid_meta, poses[p], hits, frees, params)
        refined = score > minimum_score and gn_iterations > 0
        info = np.zeros((3, 3))
        if not score > minimum_score:
            start = poses[p].copy()
        elif refined:
            start, info = line_iterate(pr, hc, mo, meta, params[3], int(params[4]), hits, frees,
                                       start, gn_iterations, gn_max_angle_step, prior_mean[p],
                                       prior_info)
        mu, cov, log_eta[p] = proposal_moments(pr, mo, corner, grid_meta, start, prior_mean[p],
                                               prior_std, hits, frees, params)
        if refined and np.linalg.det(info) > 0.0:
            cov = np.linalg.inv(info)
        for a in range(3):  # element writes: see _match_kernel._copy3
            means[p, a] = mu[a]
            for b in range(3):
                covs[p, a, b] = cov[a, b]
    return means, covs, log_eta


def box_patch(table, pool, grid_meta, box):
    """One particle's patch over box (first row, column, rows, columns) in arrays of its own:
    read_patch's (prob, hits, mean_off) and the patch's [ox, oy, resolution, rows, columns]."""
    nr, nc = int(box[2]), int(box[3])
    prob, hits = np.empty((nr, nc), np.float32), np.empty((nr, nc), np.float32)
    mean_off = np.empty((nr, nc, 2), np.float32)
    read_patch(table, pool, grid_meta, box, box, prob, hits, mean_off)
    return prob, hits, mean_off, _patch_meta(grid_meta, box)


def propose_particles_ref(tables, pool, grid_meta, poses, prior_mean, prior_std, hits, frees,
                          params, half, room, gn_iterations, gn_max_angle_step, gn_prior_w,
                          minimum_score):
    """propose_particles written as a Python loop over the single-particle kernels, each
    particle's patch in arrays of its own, every cell of its box read (room is not used)."""
    out = []
    for p in range(len(poses)):
        box = np.empty(4, dtype=np.int64)
        patch_box(tables[p], grid_meta, poses[p], half, box)
        prob, hits_n, mean_off, meta = box_patch(tables[p], pool, grid_meta, box)
        start, score = hill_climb(prob, mean_off, box[:2], grid_meta, poses[p], hits, frees,
                                  params)
        info = None
        if score <= minimum_score:
            start = poses[p].copy()
        elif gn_iterations > 0:
            start, info = line_iterate(prob, hits_n, mean_off, meta, params[3], int(params[4]),
                                       hits, frees, start, gn_iterations, gn_max_angle_step,
                                       prior_mean[p], np.diag(gn_prior_w))
        mu, cov, log_eta = proposal_moments(prob, mean_off, box[:2], grid_meta, start,
                                            prior_mean[p], prior_std, hits, frees, params)
        if info is not None and np.linalg.det(info) > 0.0:
            cov = np.linalg.inv(info)
        out.append((mu, cov, log_eta))
    return (np.array([o[0] for o in out]), np.array([o[1] for o in out]),
            np.array([o[2] for o in out]))
