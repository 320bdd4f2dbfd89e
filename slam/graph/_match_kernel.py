"""Scan-to-grid least squares, as Cartographer's CeresScanMatcher2D (Hess et al. 2016, Sec. IV-C).

Minimises over the pose xi = (x, y, theta)
    sum_i (w_occ / sqrt(N) * (1 - M(T_xi p_i)))^2 + (w_t * (t - t_prior))^2 + (w_r * (theta - theta_prior))^2
(with per-point weights w_i / sum w in place of 1/N when given) where M is the bilinearly interpolated probability grid (slam._kernels.interp), with a few
Levenberg-Marquardt steps (Cartographer runs ceres with bicubic interpolation; bilinear is
the shared core's interpolation and gives the same minimum up to a fraction of a cell).

match_lm_directional: the same least squares on a directional TSDF (slam.graph.tsdf): each
point reads, in place of M, 1 - tsd / truncation of the two directional layers its normal falls
between (mix: (N, 4) k0, share, k1, share, from slam.graph._tsdf_kernel.direction_mix), the two
mixed per cell by share x cell weight; a cell neither layer has observed reads 0, as a
never-observed cell of the one field.

match_lm, match_lm_directional: compiled; *_ref: scipy.optimize.least_squares on the numpy
reference interpolation, for tests.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from slam._kernels.gauss_newton import solve3
from slam._kernels.interp import (add_normal_row, bilinear, bilinear_cell, interp_point, interp_value_grad_ref,
                                  symmetrize_upper)

__all__ = ["match_lm", "match_lm_ref", "match_lm_directional", "match_lm_directional_ref",
           "directional_value_ref"]


@njit(cache=True, nogil=True)
def _dir_cell(dir_tsd, dir_weight, truncation, k0, a0, k1, a1, j, i):
    s = a0 * dir_weight[k0, j, i] + a1 * dir_weight[k1, j, i]
    if s <= 0.0:
        return 0.0
    t = (a0 * dir_weight[k0, j, i] * dir_tsd[k0, j, i] + a1 * dir_weight[k1, j, i] * dir_tsd[k1, j, i]) / s
    return 1.0 - t / truncation


@njit(cache=True, nogil=True)
def _interp(prob, dir_tsd, dir_weight, truncation, mix, k, ox, oy, res, rows, cols, x, y):
    """(M, dM/dx, dM/dy) of point k at x, y: the one grid (mix empty) or its directional layers."""
    if mix.shape[0] == 0:
        return interp_point(prob, ox, oy, res, rows, cols, x, y)
    i, j, fu, fv = bilinear_cell(ox, oy, res, rows, cols, x, y)
    if i < 0:
        return 0.0, 0.0, 0.0
    k0, a0, k1, a1 = int(mix[k, 0]), mix[k, 1], int(mix[k, 2]), mix[k, 3]
    return bilinear(_dir_cell(dir_tsd, dir_weight, truncation, k0, a0, k1, a1, j, i),
                    _dir_cell(dir_tsd, dir_weight, truncation, k0, a0, k1, a1, j, i + 1),
                    _dir_cell(dir_tsd, dir_weight, truncation, k0, a0, k1, a1, j + 1, i),
                    _dir_cell(dir_tsd, dir_weight, truncation, k0, a0, k1, a1, j + 1, i + 1), fu, fv, res)


@njit(cache=True, nogil=True)
def _cost_grad(prob, dir_tsd, dir_weight, truncation, mix, meta, pts, wts, pose, prior, w_occ, w_t, w_r, H, g):
    ox, oy, res = meta[0], meta[1], meta[2]
    rows, cols = int(meta[3]), int(meta[4])
    n = pts.shape[0]
    wsum = 0.0
    for k in range(n):
        wsum += wts[k]
    if wsum <= 0.0:
        wsum = 1.0
    c, sn = np.cos(pose[2]), np.sin(pose[2])
    for a in range(3):
        g[a] = 0.0
        for b in range(3):
            H[a, b] = 0.0
    cost = 0.0
    for k in range(n):
        px, py = pts[k, 0], pts[k, 1]
        x = pose[0] + c * px - sn * py
        y = pose[1] + sn * px + c * py
        m, mx, my = _interp(prob, dir_tsd, dir_weight, truncation, mix, k, ox, oy, res, rows, cols, x, y)
        s = w_occ * np.sqrt(wts[k] / wsum)
        r = s * (1.0 - m)
        j0 = -s * mx
        j1 = -s * my
        j2 = -s * (mx * (-sn * px - c * py) + my * (c * px - sn * py))
        cost += r * r
        add_normal_row(H, g, j0, j1, j2, r)
    symmetrize_upper(H)
    for a in range(2):
        r = w_t * (pose[a] - prior[a])
        cost += r * r
        g[a] += w_t * r
        H[a, a] += w_t * w_t
    r = w_r * (pose[2] - prior[2])
    cost += r * r
    g[2] += w_r * r
    H[2, 2] += w_r * w_r
    return cost


@njit(cache=True, nogil=True)
def match_lm(prob, meta, pts, wts, pose0, prior, w_occ, w_t, w_r, iterations):
    """Pose minimising the scan-matching cost, from pose0.

    prob: (rows, cols) finite probabilities; meta: (5,) [ox, oy, res, rows, cols]; pts: (N, 2)
    m in the robot frame; wts: (N,) point weights (normalised to sum 1 inside; all equal =
    Cartographer's 1/N); pose0, prior: (3,) x, y, yaw (yaw prior as an unwrapped angle near
    pose0's); w_occ, w_t, w_r: occupied-space, translation, rotation weights.
    Returns (pose (3,), final cost).
    """
    none = np.zeros((0, 1, 1))
    return _lm(prob, none, none, 1.0, np.zeros((0, 4)), meta, pts, wts, pose0, prior, w_occ, w_t, w_r, iterations)


@njit(cache=True, nogil=True)
def match_lm_directional(dir_tsd, dir_weight, truncation, mix, meta, pts, wts, pose0, prior, w_occ, w_t, w_r,
                         iterations):
    """match_lm on the directional layers dir_tsd, dir_weight (K, rows, cols) of a TSDF of the
    given truncation (m); mix (N, 4): each point's two layers and their shares."""
    return _lm(np.zeros((1, 1)), dir_tsd, dir_weight, truncation, mix, meta, pts, wts, pose0, prior, w_occ, w_t,
               w_r, iterations)


@njit(cache=True, nogil=True)
def _lm(prob, dir_tsd, dir_weight, truncation, mix, meta, pts, wts, pose0, prior, w_occ, w_t, w_r, iterations):
    pose = pose0.copy()
    H = np.zeros((3, 3))
    g = np.zeros(3)
    Ht = np.zeros((3, 3))
    gt = np.zeros(3)
    cost = _cost_grad(prob, dir_tsd, dir_weight, truncation, mix, meta, pts, wts, pose, prior, w_occ, w_t, w_r, H, g)
    lam = 1e-3
    for _ in range(iterations):
        A = H.copy()
        for a in range(3):
            A[a, a] += lam * (H[a, a] + 1e-9)
        # Cramer's rule: np.linalg.solve gives the same step, but its compiled form costs 4-5 s
        # of a cold start
        step, solved = solve3(A, -g)
        if not solved:
            break
        trial = pose + step
        tcost = _cost_grad(prob, dir_tsd, dir_weight, truncation, mix, meta, pts, wts, trial, prior, w_occ, w_t, w_r,
                           Ht, gt)
        if tcost < cost:
            pose = trial
            done = cost - tcost < 1e-10 * cost
            cost = tcost
            for a in range(3):  # element writes, not H[:, :] = Ht: see pf's _copy3
                g[a] = gt[a]
                for b in range(3):
                    H[a, b] = Ht[a, b]
            lam = max(lam * 0.3, 1e-7)
            if done:
                break
        else:
            lam *= 10.0
            if lam > 1e6:
                break
    return pose, cost


def match_lm_ref(prob, meta, pts, wts, pose0, prior, w_occ, w_t, w_r, iterations=50):
    """Reference: scipy least squares over the same residuals with numpy interpolation."""
    return _lm_ref(lambda xy: interp_value_grad_ref(prob, meta, xy)[:, 0], pts, wts, pose0, prior, w_occ, w_t, w_r,
                   iterations)


def _lm_ref(values, pts, wts, pose0, prior, w_occ, w_t, w_r, iterations):
    """scipy least squares of the matching cost with M of world points (N, 2) from values."""
    from scipy.optimize import least_squares
    pts = np.asarray(pts, np.float64)
    wts = np.asarray(wts, np.float64)
    s = w_occ * np.sqrt(wts / wts.sum())

    def fun(p):
        c, sn = np.cos(p[2]), np.sin(p[2])
        w = np.stack([p[0] + c * pts[:, 0] - sn * pts[:, 1], p[1] + sn * pts[:, 0] + c * pts[:, 1]], 1)
        return np.concatenate([s * (1 - values(w)), w_t * (p[:2] - prior[:2]), [w_r * (p[2] - prior[2])]])

    res = least_squares(fun, np.asarray(pose0, float), method="lm", max_nfev=iterations * 10,
                        xtol=1e-12, ftol=1e-12)
    return res.x, float(np.sum(res.fun ** 2))


def directional_value_ref(dir_tsd, dir_weight, truncation, meta, xy, mix):
    """(N,) the directional M of points xy (N, 2) m with their mix (N, 4), in numpy."""
    ox, oy, res, rows, cols = meta
    out = np.zeros(len(xy))
    for n, ((x, y), (k0, a0, k1, a1)) in enumerate(zip(np.asarray(xy, float), mix)):
        u, v = (x - ox) / res - 0.5, (y - oy) / res - 0.5
        i, j = int(np.floor(u)), int(np.floor(v))
        if i < 0 or j < 0 or i + 1 >= cols or j + 1 >= rows:
            continue
        layers = [(int(k0), a0), (int(k1), a1)]

        def cell(jj, ii):
            w = np.array([a * dir_weight[k, jj, ii] for k, a in layers])
            if w.sum() <= 0:
                return 0.0
            return 1.0 - float(w @ [dir_tsd[k, jj, ii] for k, _ in layers]) / w.sum() / truncation

        fu, fv = u - i, v - j
        out[n] = ((1 - fv) * ((1 - fu) * cell(j, i) + fu * cell(j, i + 1))
                  + fv * ((1 - fu) * cell(j + 1, i) + fu * cell(j + 1, i + 1)))
    return out


def match_lm_directional_ref(dir_tsd, dir_weight, truncation, mix, meta, pts, wts, pose0, prior, w_occ, w_t, w_r,
                             iterations=50):
    """Reference of match_lm_directional: scipy least squares over the same residuals."""
    return _lm_ref(lambda xy: directional_value_ref(dir_tsd, dir_weight, truncation, meta, xy, mix), pts, wts, pose0,
                   prior, w_occ, w_t, w_r, iterations)
