"""Gmapping's scan matcher on the per-particle count maps (Grisetti et al. 2007, GMapping
ScanMatcher: score, likelihoodAndScore, optimize, and the sampled proposal moments).

For every beam with a return, the hit point h and a point one cell before it along the beam
(the "free" point f) are placed by the pose. In a (2 kernel + 1)^2 window around h's cell,
a cell counts as a match when it is occupied (n / visits > fullness) and the cell at the
same offset from f's cell is not (unknown counts as not occupied); of the matches the one
whose mean hit point is nearest to h gives d^2. Then
    score      = sum over matched beams of exp(-d^2 / sigma)
    likelihood = sum over beams of (-d^2 / lsigma if matched else null_likelihood / lsigma)

params (float64 array, one small array instead of many arguments):
    [0] sigma  [1] lsigma  [2] null_likelihood  [3] fullness  [4] kernel
    [5] lstep  [6] astep   [7] iterations
    [8] llsamplerange  [9] llsamplestep  [10] lasamplerange  [11] lasamplestep

The compiled kernels score against a dense patch of one particle's map around its pose
(slam.pf._map_kernel.read_patch: hits / visits and the mean hit points' offsets in their cells,
read once per update), which makes the many evaluations of the hill climbing plain array
reads. A cell is occupied when hits / visits > fullness (so fullness >= 0).

Kernels and references:
  score_and_likelihood (one pose)     <-> score_and_likelihood_ref (dense counters)
  hill_climb (one particle)           <-> hill_climb_ref (plain loop over the reference score)
  grid_likelihoods (proposal grid)    <-> score_and_likelihood at each grid pose
  proposal_moments (one particle)     <-> proposal_moments_ref
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["PARAMS", "make_params", "score_and_likelihood", "beam_cache",
           "score_above", "hill_climb", "grid_likelihoods", "proposal_moments",
           "score_and_likelihood_ref", "hill_climb_ref", "proposal_moments_ref"]

PARAMS = ("sigma", "lsigma", "null_likelihood", "fullness", "kernel", "lstep", "astep",
          "iterations", "llsamplerange", "llsamplestep", "lasamplerange", "lasamplestep")


def make_params(**kw) -> np.ndarray:
    """The params array from keyword values named as in PARAMS (all required)."""
    return np.array([float(kw[k]) for k in PARAMS])


# Reordered floating point (no ninf/nnan: `best` starts at inf) is about 10 % faster on the
# filter's hottest loop; trajectories differ from strict IEEE order by ~1e-14 m.
_FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}


@njit(cache=True, fastmath=_FAST, inline="always")
def _beam_cells(ox, oy, res, pose, c, s, hit, free):
    """A beam placed by pose (cos c, sin s) in a patch with origin (ox, oy): its hit point
    hx, hy, the hit's cell row, column and the free point's cell offset from it."""
    hx = pose[0] + c * hit[0] - s * hit[1]
    hy = pose[1] + s * hit[0] + c * hit[1]
    hc = int(math.floor((hx - ox) / res))
    hr = int(math.floor((hy - oy) / res))
    dc = int(math.floor((pose[0] + c * free[0] - s * free[1] - ox) / res)) - hc
    dr = int(math.floor((pose[1] + s * free[0] + c * free[1] - oy) / res)) - hr
    return hx, hy, hr, hc, dr, dc


@njit(cache=True)
def _mean_hit(corner, grid_meta, r, c, mean_off):
    """World x, y of the mean hit point of patch cell (r, c), rounded to float32 (the
    counters' precision), in strict IEEE order wherever it is read from."""
    res = grid_meta[2]
    return (np.float32(grid_meta[0] + (corner[1] + c) * res + mean_off[r, c, 0]),
            np.float32(grid_meta[1] + (corner[0] + r) * res + mean_off[r, c, 1]))


@njit(cache=True, fastmath=_FAST, inline="always")
def _candidates(prob, mean_off, corner, grid_meta, fullness, hr, hc, dr, dc, kernel, cand_x,
                cand_y):
    """Mean hit points of the cells in the (2 kernel + 1)^2 window around patch cell (hr, hc)
    that are occupied while the cell at offset (dr, dc) from them (the free point's) is not,
    into cand_x, cand_y in window order; returns their count."""
    size_r, size_c = prob.shape
    n = 0
    for yy in range(-kernel, kernel + 1):
        r = hr + yy
        if r < 0 or r >= size_r:
            continue
        for xx in range(-kernel, kernel + 1):
            cc = hc + xx
            if cc < 0 or cc >= size_c or not prob[r, cc] > fullness:
                continue
            fr = r + dr
            fc = cc + dc
            if 0 <= fr < size_r and 0 <= fc < size_c and prob[fr, fc] > fullness:
                continue
            cand_x[n], cand_y[n] = _mean_hit(corner, grid_meta, r, cc, mean_off)
            n += 1
    return n


@njit(cache=True, fastmath=_FAST, inline="always")
def _nearest_d2(hx, hy, cand_x, cand_y, n):
    """Smallest squared distance from (hx, hy) to the first n candidates; inf when n is 0."""
    best = np.inf
    for q in range(n):
        d2 = (hx - cand_x[q]) ** 2 + (hy - cand_y[q]) ** 2
        if d2 < best:
            best = d2
    return best


@njit(cache=True, fastmath=_FAST, nogil=True)
def score_and_likelihood(prob, mean_off, corner, grid_meta, pose, hits, frees, params):
    """(score, log likelihood) of one robot pose (3,) against one particle's map patch.

    prob: (R, C) hits / visits, mean_off: (R, C, 2) (see read_patch); corner: (2,) row,
    column of the patch in the grid; hits, frees: (K, 2) robot frame, m.
    """
    sigma, lsigma, null_l, fullness = params[0], params[1], params[2], params[3]
    kernel = int(params[4])
    res = grid_meta[2]
    ox = grid_meta[0] + corner[1] * res
    oy = grid_meta[1] + corner[0] * res
    cand_x = np.empty((2 * kernel + 1) ** 2)
    cand_y = np.empty((2 * kernel + 1) ** 2)
    c = math.cos(pose[2])
    s = math.sin(pose[2])
    score = 0.0
    lik = 0.0
    no_hit = null_l / lsigma
    for k in range(hits.shape[0]):
        hx, hy, hr, hc, dr, dc = _beam_cells(ox, oy, res, pose, c, s, hits[k], frees[k])
        n = _candidates(prob, mean_off, corner, grid_meta, fullness, hr, hc, dr, dc, kernel,
                        cand_x, cand_y)
        best = _nearest_d2(hx, hy, cand_x, cand_y, n)
        if best < np.inf:
            score += math.exp(-best / sigma)
            lik += -best / lsigma
        else:
            lik += no_hit
    return score, lik


# A beam scores at most exp(0) = 1; the slack covers a fast exp that rounds above it.
_BEAM_MAX = 1.0 + 1e-6


@njit(cache=True, nogil=True)
def beam_cache(n_beams, kernel):
    """Scratch for score_above: per beam the cells it last fell in, keys (n, 4) int64 (hit
    row, column, free point's row and column offset), and the matching candidates found
    there, count (n,) int64 (-1: none yet) and x, y (n, (2 kernel + 1)^2)."""
    width = (2 * kernel + 1) ** 2
    return (np.zeros((n_beams, 4), np.int64), np.full(n_beams, -1, np.int64),
            np.empty((n_beams, width)), np.empty((n_beams, width)))


@njit(cache=True, fastmath=_FAST, nogil=True)
def score_above(prob, mean_off, corner, grid_meta, pose, hits, frees, params, bound, keys, count,
                cand_x, cand_y):
    """score_and_likelihood's score when it exceeds `bound`; otherwise some value <= bound,
    returned as soon as the beams left (at most 1 each) cannot lift the sum above it.

    The hill climb only asks whether a move beats the current score, so most rejected
    moves stop part way through the scan. Its moves are small, so a beam mostly falls in
    the cells it fell in at the last pose: its candidates are kept in the beam_cache
    (keys, count, cand_x, cand_y) and gathered again only when those cells change. A score
    above the bound is the same sum, in the same order, as score_and_likelihood's.
    """
    sigma, fullness = params[0], params[3]
    kernel = int(params[4])
    res = grid_meta[2]
    ox = grid_meta[0] + corner[1] * res
    oy = grid_meta[1] + corner[0] * res
    c = math.cos(pose[2])
    s = math.sin(pose[2])
    n = hits.shape[0]
    score = 0.0
    for k in range(n):
        hx, hy, hr, hc, dr, dc = _beam_cells(ox, oy, res, pose, c, s, hits[k], frees[k])
        if not (count[k] >= 0 and keys[k, 0] == hr and keys[k, 1] == hc and keys[k, 2] == dr
                and keys[k, 3] == dc):
            keys[k, 0] = hr
            keys[k, 1] = hc
            keys[k, 2] = dr
            keys[k, 3] = dc
            count[k] = _candidates(prob, mean_off, corner, grid_meta, fullness, hr, hc, dr, dc,
                                   kernel, cand_x[k], cand_y[k])
        best = _nearest_d2(hx, hy, cand_x[k], cand_y[k], count[k])
        if best < np.inf:
            score += math.exp(-best / sigma)
        if score + (n - k - 1) * _BEAM_MAX <= bound:
            return min(score, bound)
    return score


@njit(cache=True, inline="always")
def _copy3(dst, src):
    """dst[:3] = src[:3] as element writes (a slice copy makes numba compile its
    shape-mismatch error message, seconds of a cold start)."""
    dst[0] = src[0]
    dst[1] = src[1]
    dst[2] = src[2]


@njit(cache=True, nogil=True)
def hill_climb(prob, mean_off, corner, grid_meta, init, hits, frees, params):
    """Gmapping's optimize(): scan-match one particle against its map patch from pose init
    (3,) by axis moves in x, y and yaw, halving the steps when none improves. Returns the
    matched pose (3,) and its score."""
    ldelta, adelta, iterations = params[5], params[6], int(params[7])
    cur = init.copy()
    cur_score, _ = score_and_likelihood(prob, mean_off, corner, grid_meta, cur, hits, frees,
                                        params)
    keys, count, cand_x, cand_y = beam_cache(hits.shape[0], int(params[4]))
    best_score = -1.0
    refinement = 0
    trial = np.empty(3)
    came_by = -1
    while True:
        if best_score >= cur_score:
            refinement += 1
            ldelta *= 0.5
            adelta *= 0.5
            came_by = -1
        best_score = cur_score
        best_local = cur.copy()
        accepted = -1
        for move in range(6):
            # the reverse of the move that led here (same step) returns to the previous pose,
            # whose score is lower than the current one: it can never be accepted
            if came_by >= 0 and move == (came_by ^ 1):
                continue
            _copy3(trial, cur)
            if move == 0:
                trial[0] += ldelta
            elif move == 1:
                trial[0] -= ldelta
            elif move == 2:
                trial[1] -= ldelta
            elif move == 3:
                trial[1] += ldelta
            elif move == 4:
                trial[2] += adelta
            else:
                trial[2] -= adelta
            sc = score_above(prob, mean_off, corner, grid_meta, trial, hits, frees, params, cur_score,
                             keys, count, cand_x, cand_y)
            if sc > cur_score:
                cur_score = sc
                _copy3(best_local, trial)
                accepted = move
        _copy3(cur, best_local)
        came_by = accepted
        if not (cur_score > best_score or refinement < iterations):
            break
    return cur, best_score


@njit(cache=True, fastmath=_FAST, nogil=True)
def grid_likelihoods(prob, mean_off, corner, grid_meta, pose, nl, ls, na, ast, hits, frees, params,
                     out):
    """score_and_likelihood's log likelihood at every pose of the proposal grid pose +
    (ix ls, iy ls, ia ast), |ix|, |iy| <= nl, |ia| <= na, into out[j], j in (ix, iy, ia)
    order.

    Beam by beam: the grid's translations are a fraction of a cell, so a beam's hit and free
    cells mostly stay put from one pose to the next, and with them its matching candidates;
    those are gathered again only when the cells change. Each pose's sum runs over the beams
    in the same order as score_and_likelihood's.
    """
    lsigma, null_l, fullness = params[1], params[2], params[3]
    kernel = int(params[4])
    no_hit = null_l / lsigma
    res = grid_meta[2]
    ox = grid_meta[0] + corner[1] * res
    oy = grid_meta[1] + corner[0] * res
    cand_x = np.empty((2 * kernel + 1) ** 2)
    cand_y = np.empty((2 * kernel + 1) ** 2)
    out[:] = 0.0
    n_ang = 2 * na + 1
    for ia in range(-na, na + 1):
        yaw = pose[2] + ia * ast
        c = math.cos(yaw)
        s = math.sin(yaw)
        for k in range(hits.shape[0]):
            rhx = c * hits[k, 0] - s * hits[k, 1]
            rhy = s * hits[k, 0] + c * hits[k, 1]
            rfx = c * frees[k, 0] - s * frees[k, 1]
            rfy = s * frees[k, 0] + c * frees[k, 1]
            key_set = False
            key_hc = key_hr = key_dc = key_dr = 0
            n_cand = 0
            for ix in range(-nl, nl + 1):
                px = pose[0] + ix * ls
                for iy in range(-nl, nl + 1):
                    py = pose[1] + iy * ls
                    hx = px + rhx
                    hy = py + rhy
                    hc = int(math.floor((hx - ox) / res))
                    hr = int(math.floor((hy - oy) / res))
                    dc = int(math.floor((px + rfx - ox) / res)) - hc
                    dr = int(math.floor((py + rfy - oy) / res)) - hr
                    if not (key_set and hc == key_hc and hr == key_hr and dc == key_dc
                            and dr == key_dr):
                        key_set = True
                        key_hc, key_hr, key_dc, key_dr = hc, hr, dc, dr
                        n_cand = _candidates(prob, mean_off, corner, grid_meta, fullness, hr, hc,
                                             dr, dc, kernel, cand_x, cand_y)
                    best = _nearest_d2(hx, hy, cand_x, cand_y, n_cand)
                    j = ((ix + nl) * (2 * nl + 1) + iy + nl) * n_ang + ia + na
                    out[j] += -best / lsigma if best < np.inf else no_hit


@njit(cache=True, nogil=True)
def proposal_moments(prob, mean_off, corner, grid_meta, pose, prior_mean, prior_std, hits, frees,
                     params):
    """Gaussian proposal around one particle's matched pose from likelihood x motion prior, on
    its map patch (see score_and_likelihood).

    At the poses of the grid pose + (dx, dy, dyaw), dx, dy in -llsamplerange ..
    llsamplerange by llsamplestep, dyaw likewise with the angular values, the target is
    exp(log likelihood + log N(pose; prior_mean, diag(prior_std^2))). pose, prior_mean,
    prior_std: (3,). Returns the weighted mean (3,), covariance (3, 3) and log eta, eta =
    the sum of the target over the grid (the normaliser the particle's weight is multiplied
    by).
    """
    lr, ls, ar, ast = params[8], params[9], params[10], params[11]
    nl = int(round(lr / ls)) if ls > 0 else 0
    na = int(round(ar / ast)) if ast > 0 else 0
    m = (2 * nl + 1) * (2 * nl + 1) * (2 * na + 1)
    samples = np.empty((m, 3))
    logt = np.empty(m)
    lik = np.empty(m)
    grid_likelihoods(prob, mean_off, corner, grid_meta, pose, nl, ls, na, ast, hits, frees, params,
                     lik)
    j = 0
    for ix in range(-nl, nl + 1):
        for iy in range(-nl, nl + 1):
            for ia in range(-na, na + 1):
                samples[j, 0] = pose[0] + ix * ls
                samples[j, 1] = pose[1] + iy * ls
                samples[j, 2] = pose[2] + ia * ast
                lp = 0.0
                for d in range(3):
                    e = samples[j, d] - prior_mean[d]
                    if d == 2:
                        e = (e + math.pi) % (2 * math.pi) - math.pi
                    lp += -0.5 * (e / prior_std[d]) ** 2 - math.log(prior_std[d])
                logt[j] = lik[j] + lp
                j += 1
    lmax = logt.max()
    wsum = 0.0
    mu = np.zeros(3)
    for j in range(m):
        w = math.exp(logt[j] - lmax)
        wsum += w
        mu += w * samples[j]
    mu /= wsum
    cov = np.zeros((3, 3))
    for j in range(m):
        w = math.exp(logt[j] - lmax) / wsum
        e = samples[j] - mu
        for a in range(3):
            for b in range(3):
                cov[a, b] += w * e[a] * e[b]
    return mu, cov, lmax + math.log(wsum)


# --- references (dense counters (rows, cols, 4) as insert_scan_ref builds them) -------------

def _dense_cell(counts, grid_meta, r, c):
    rows, cols = counts.shape[:2]
    if not (0 <= r < rows and 0 <= c < cols) or counts[r, c, 1] <= 0:
        return None
    n, v = counts[r, c, 0], counts[r, c, 1]
    res = grid_meta[2]
    mean = None
    if n > 0:
        mean = np.array([grid_meta[0] + c * res + counts[r, c, 2] / n,
                         grid_meta[1] + r * res + counts[r, c, 3] / n])
    return n / v, mean


def score_and_likelihood_ref(counts, grid_meta, pose, hits, frees, params):
    """Plain statement of score_and_likelihood on dense counters (rows, cols, 4)."""
    sigma, lsigma, null_l, fullness, kernel = params[:5]
    kernel = int(kernel)
    rot = np.array([[np.cos(pose[2]), -np.sin(pose[2])], [np.sin(pose[2]), np.cos(pose[2])]])
    h_w = hits @ rot.T + pose[:2]
    f_w = frees @ rot.T + pose[:2]
    cell = lambda p: np.floor((p - grid_meta[:2]) / grid_meta[2]).astype(int)  # (col, row)
    score = lik = 0.0
    for h, f in zip(h_w, f_w):
        hc, fc = cell(h), cell(f)
        d2s = []
        for yy in range(-kernel, kernel + 1):
            for xx in range(-kernel, kernel + 1):
                occ = _dense_cell(counts, grid_meta, hc[1] + yy, hc[0] + xx)
                if occ is None or occ[0] <= fullness:
                    continue
                free = _dense_cell(counts, grid_meta, fc[1] + yy, fc[0] + xx)
                if free is not None and free[0] > fullness:
                    continue
                d2s.append(float(np.sum((h - occ[1]) ** 2)))
        if d2s:
            score += np.exp(-min(d2s) / sigma)
            lik += -min(d2s) / lsigma
        else:
            lik += null_l / lsigma
    return score, lik


def hill_climb_ref(counts, grid_meta, init, hits, frees, params):
    """Gmapping's optimize() written plainly over the reference score; returns (pose, score)."""
    ldelta, adelta, iterations = params[5], params[6], int(params[7])
    score = lambda q: score_and_likelihood_ref(counts, grid_meta, q, hits, frees, params)[0]
    cur = np.array(init, dtype=float)
    cur_score = score(cur)
    best_score, refinement, back = -1.0, 0, None
    moves = lambda l, a: [(l, 0, 0), (-l, 0, 0), (0, -l, 0), (0, l, 0), (0, 0, a), (0, 0, -a)]
    reverse = {0: 1, 1: 0, 2: 3, 3: 2, 4: 5, 5: 4}
    while True:
        if best_score >= cur_score:
            refinement += 1
            ldelta, adelta = ldelta / 2, adelta / 2
            back = None
        best_score = cur_score
        # the move back to the previous pose (lower score) is not tried
        cands = [(score(cur + np.array(mv)), i) for i, mv in enumerate(moves(ldelta, adelta))
                 if i != back]
        better = [(s, i) for s, i in cands if s > cur_score]
        back = None
        if better:
            # the strictly best move, first in move order on ties (as the sequential scan)
            top = max(s for s, _ in better)
            i = min(i for s, i in better if s == top)
            cur, cur_score = cur + np.array(moves(ldelta, adelta)[i]), top
            back = reverse[i]
        if not (cur_score > best_score or refinement < iterations):
            return cur, best_score


def proposal_moments_ref(counts, grid_meta, pose, prior_mean, prior_std, hits, frees, params):
    """Plain statement of proposal_moments for one particle: (mean (3,), cov (3, 3), log eta)."""
    lr, ls, ar, ast = params[8:12]
    offs = [(x, y, a) for x in np.arange(-round(lr / ls), round(lr / ls) + 1) * ls
            for y in np.arange(-round(lr / ls), round(lr / ls) + 1) * ls
            for a in np.arange(-round(ar / ast), round(ar / ast) + 1) * ast]
    xs = np.array(pose) + np.array(offs)
    logt = []
    for q in xs:
        lik = score_and_likelihood_ref(counts, grid_meta, q, hits, frees, params)[1]
        e = q - prior_mean
        e[2] = (e[2] + np.pi) % (2 * np.pi) - np.pi
        logt.append(lik + np.sum(-0.5 * (e / prior_std) ** 2 - np.log(prior_std)))
    logt = np.array(logt)
    log_eta = np.logaddexp.reduce(logt)
    w = np.exp(logt - log_eta)
    mean = w @ xs
    cov = (xs - mean).T @ ((xs - mean) * w[:, None])
    return mean, cov, float(log_eta)
