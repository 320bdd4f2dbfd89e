"""Scan-to-grid least squares, as Cartographer's CeresScanMatcher2D (Hess et al. 2016, Sec. IV-C).

Minimises over the pose xi = (x, y, theta)
    sum_i (w_occ / sqrt(N) * (1 - M(T_xi p_i)))^2 + (w_t * (t - t_prior))^2 + (w_r * (theta - theta_prior))^2
(with per-point weights w_i / sum w in place of 1/N when given) where M is the bilinearly interpolated probability grid (slam._kernels.interp), with a few
Levenberg-Marquardt steps (Cartographer runs ceres with bicubic interpolation; bilinear is
the shared core's interpolation and gives the same minimum up to a fraction of a cell).

match_lm: compiled; match_lm_ref: scipy.optimize.least_squares on the numpy reference
interpolation, for tests.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from slam._kernels.interp import add_normal_row, interp_point, interp_value_grad_ref, symmetrize_upper

__all__ = ["match_lm", "match_lm_ref"]


@njit(cache=True, nogil=True)
def _cost_grad(prob, meta, pts, wts, pose, prior, w_occ, w_t, w_r, H, g):
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
        m, mx, my = interp_point(prob, ox, oy, res, rows, cols, x, y)
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
    pose = pose0.copy()
    H = np.zeros((3, 3))
    g = np.zeros(3)
    Ht = np.zeros((3, 3))
    gt = np.zeros(3)
    cost = _cost_grad(prob, meta, pts, wts, pose, prior, w_occ, w_t, w_r, H, g)
    lam = 1e-3
    for _ in range(iterations):
        A = H.copy()
        for a in range(3):
            A[a, a] += lam * (H[a, a] + 1e-9)
        step = np.linalg.solve(A, -g)
        trial = pose + step
        tcost = _cost_grad(prob, meta, pts, wts, trial, prior, w_occ, w_t, w_r, Ht, gt)
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
    from scipy.optimize import least_squares
    pts = np.asarray(pts, np.float64)
    wts = np.asarray(wts, np.float64)
    s = w_occ * np.sqrt(wts / wts.sum())

    def fun(p):
        c, sn = np.cos(p[2]), np.sin(p[2])
        w = np.stack([p[0] + c * pts[:, 0] - sn * pts[:, 1], p[1] + sn * pts[:, 0] + c * pts[:, 1]], 1)
        m = interp_value_grad_ref(prob, meta, w)[:, 0]
        return np.concatenate([s * (1 - m), w_t * (p[:2] - prior[:2]), [w_r * (p[2] - prior[2])]])

    res = least_squares(fun, np.asarray(pose0, float), method="lm", max_nfev=iterations * 10,
                        xtol=1e-12, ftol=1e-12)
    return res.x, float(np.sum(res.fun ** 2))
