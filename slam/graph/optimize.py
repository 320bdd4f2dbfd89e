"""Sparse pose adjustment (Konolige et al. 2010) as Cartographer's 2D optimization problem.

Variables: the global poses of all submaps and all nodes (scans kept by the motion filter).
Each constraint says "node j seen from submap i is at z" (the relative pose in submap i's
frame), with a translation and a rotation weight. The residual is Cartographer's
`ScaleError(z^-1 (x) (submap^-1 (x) node))`: the error pose scaled *by* the weights (not by
their square roots), so the cost of one constraint is 0.5 * (w_t^2 |dt|^2 + w_r^2 dtheta^2).
Loop-closure constraints (Cartographer's INTER_SUBMAP tag) go through a Huber loss of scale
`huber_scale`, so one wrong loop closure pulls with bounded force; the local ones
(INTRA_SUBMAP, from the local SLAM) do not. Consecutive nodes are tied together by their
local-SLAM relative motion (local_slam_pose_*_weight). The gauge is fixed by holding the
first submap at its current pose, as Cartographer does.

Solved by Levenberg-Marquardt on the sparse normal equations (SPA, Konolige et al. 2010;
Cartographer's Ceres with SPARSE_NORMAL_CHOLESKY): J^T W J + lambda diag, factorised by
scipy.sparse.linalg (SuperLU), the Huber loss by iteratively reweighted least squares. A
pose graph ordered submaps first, then nodes in time order, has an "arrow" normal matrix:
nodes meet only their neighbours in time (a narrow band) and the few submaps (the border);
such a system is solved by a banded Cholesky and the submaps' Schur complement instead
(`solve_spd`: 2-3x faster than SuperLU on a swirl_l graph of 1900 nodes, the same solution
to 1e-13).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import LinAlgError, cho_factor, cho_solve
from scipy.sparse.linalg import splu

from slam.graph._band_kernel import band_cholesky_solve
from slam.pose import relative, wrap_angle

__all__ = ["Constraints", "spa_residuals", "optimize_poses", "solve_spd"]


@dataclass(frozen=True, eq=False)
class Constraints:
    """Relative-pose constraints between pose variables of one problem.

    i, j: (C,) int indices into the stacked variable array (submaps then nodes, or any
    order the caller chooses); z: (C, 3) pose of j in the frame of i (x, y m, yaw rad);
    w_t, w_r: (C,) translation (1/m) and rotation (1/rad) weights; robust: (C,) bool, Huber
    loss on this constraint (loop closures).
    """

    i: np.ndarray
    j: np.ndarray
    z: np.ndarray
    w_t: np.ndarray
    w_r: np.ndarray
    robust: np.ndarray

    def __post_init__(self):
        n = len(np.asarray(self.i))
        for name, shape in (("j", (n,)), ("z", (n, 3)), ("w_t", (n,)), ("w_r", (n,)), ("robust", (n,))):
            arr = np.asarray(getattr(self, name))
            if arr.shape != shape:
                raise ValueError(f"Constraints.{name}: expected shape {shape}, got {arr.shape}")


def spa_residuals(poses: np.ndarray, c: Constraints) -> np.ndarray:
    """(C, 3) weighted errors of the constraints at `poses` ((P, 3) global poses)."""
    rel = relative(poses[c.i], poses[c.j])
    # Error expressed in the measured frame z, as Cartographer's ComputeUnscaledError.
    ct, st = np.cos(c.z[:, 2]), np.sin(c.z[:, 2])
    dx = rel[:, 0] - c.z[:, 0]
    dy = rel[:, 1] - c.z[:, 1]
    ex = ct * dx + st * dy
    ey = -st * dx + ct * dy
    et = wrap_angle(rel[:, 2] - c.z[:, 2])
    return np.stack([c.w_t * ex, c.w_t * ey, c.w_r * et], axis=1)


def _jacobian(poses: np.ndarray, c: Constraints, free_col: np.ndarray, n_free: int) -> sp.csr_matrix:
    """Sparse d(residuals)/d(free variables) of spa_residuals, rows 3k..3k+2 for constraint k."""
    pi, pj = poses[c.i], poses[c.j]
    th = pi[:, 2]
    dtx = pj[:, 0] - pi[:, 0]
    dty = pj[:, 1] - pi[:, 1]
    ci, si = np.cos(th), np.sin(th)
    cz, sz = np.cos(c.z[:, 2]), np.sin(c.z[:, 2])
    # ex = R(z)^T R(th_i)^T (t_j - t_i) - ...; R(z)^T R(th_i)^T = R(th_i + z_th)^T
    ca, sa = np.cos(th + c.z[:, 2]), np.sin(th + c.z[:, 2])
    del ci, si, cz, sz
    n = len(c.i)
    rows, cols, vals = [], [], []

    def add(r_off, var_idx, comp, v):
        col = free_col[var_idx] * 3 + comp
        ok = free_col[var_idx] >= 0
        rows.append((np.arange(n) * 3 + r_off)[ok])
        cols.append(col[ok])
        vals.append(np.broadcast_to(v, (n,))[ok])

    wt, wr = c.w_t, c.w_r
    # d ex / d t_j = w_t * [ca, sa]; d ey / d t_j = w_t * [-sa, ca]
    add(0, c.j, 0, wt * ca); add(0, c.j, 1, wt * sa)
    add(1, c.j, 0, -wt * sa); add(1, c.j, 1, wt * ca)
    add(0, c.i, 0, -wt * ca); add(0, c.i, 1, -wt * sa)
    add(1, c.i, 0, wt * sa); add(1, c.i, 1, -wt * ca)
    # d/d th_i of [ca*dtx + sa*dty, -sa*dtx + ca*dty]
    add(0, c.i, 2, wt * (-sa * dtx + ca * dty))
    add(1, c.i, 2, wt * (-ca * dtx - sa * dty))
    add(2, c.j, 2, wr)
    add(2, c.i, 2, -wr)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(3 * n, 3 * n_free))


def optimize_poses(poses: np.ndarray, c: Constraints, fixed: np.ndarray | None = None,
                   huber_scale: float = 10.0, max_iterations: int = 50,
                   tolerance: float = 1e-5) -> np.ndarray:
    """Sparse pose adjustment: the poses that best satisfy the constraints.

    poses: (P, 3) initial global poses; c: constraints over indices into poses;
    fixed: (P,) bool, poses held constant (the gauge; default: pose 0); huber_scale: scale of
    the Huber loss on robust constraints (in weighted-residual units, Cartographer's
    optimization_problem.huber_scale); tolerance: stop when the cost falls by less than this
    fraction (ten times Ceres' function_tolerance: with the small Huber scale the last
    iterations crawl and change the map by nothing).
    Returns (P, 3) optimized poses (yaw wrapped).
    """
    poses = np.asarray(poses, dtype=np.float64).copy()
    n_poses = len(poses)
    if fixed is None:
        fixed = np.zeros(n_poses, bool)
        fixed[0] = True
    fixed = np.asarray(fixed, bool)
    if len(c.i) == 0 or fixed.all():
        return poses
    free_idx = np.flatnonzero(~fixed)
    free_col = -np.ones(n_poses, np.int64)
    free_col[free_idx] = np.arange(len(free_idx))
    robust_rows = np.repeat(np.asarray(c.robust, bool), 3)
    base = poses.copy()
    # Unwrapped yaw offsets keep the parametrisation smooth; wrap only at the end.
    x0 = np.zeros(3 * len(free_idx))

    def current(x):
        p = base.copy()
        p[free_idx] += x.reshape(-1, 3)
        return p

    def fun(x):
        return spa_residuals(current(x), c).reshape(-1)

    def jac(x):
        return _jacobian(current(x), c, free_col, len(free_idx))

    x = _sparse_lm(fun, jac, x0, robust_rows, huber_scale, max_iterations, tolerance)
    out = current(x)
    out[:, 2] = wrap_angle(out[:, 2])
    return out


def _huber(f: np.ndarray, robust_rows: np.ndarray, delta: float) -> tuple[float, np.ndarray]:
    """(cost 0.5 * sum rho(f^2), IRLS weights (len(f),)): Huber per residual component on the
    robust rows (as scipy's loss on f^2), squares elsewhere."""
    a = np.abs(f)
    big = robust_rows & (a > delta)
    rho = np.where(big, 2.0 * delta * a - delta * delta, f * f)
    w = np.ones_like(a)
    w[big] = delta / a[big]           # a > delta >= 0 there; only those are divided
    return 0.5 * float(rho.sum()), w


# Minimum degree on A^T + A suits the symmetric normal matrix (COLAMD: 4x the fill-in here).
_PERMC = "MMD_AT_PLUS_A"
# solve_spd's arrow path: at most this band (one 3x3 block and its neighbour in time), and at
# most this many entries in the dense (band x border) block it solves for (40 MB); anything
# else goes to SuperLU (a long run with hundreds of submaps)
_MAX_BAND = 5
_MAX_DENSE = 5_000_000


def _arrow_border(A: sp.csc_matrix, band: int) -> int:
    """Smallest k such that A[k:, k:] has no entry farther than `band` from its diagonal."""
    coo = A.tocoo()
    far = np.abs(coo.row - coo.col) > band
    if not far.any():
        return 0
    return int(np.minimum(coo.row[far], coo.col[far]).max()) + 1


def solve_spd(A: sp.spmatrix, g: np.ndarray) -> np.ndarray:
    """x with A x = g for a sparse symmetric positive definite A.

    When A is an arrow (a small border of k leading unknowns, the rest banded), it eliminates
    the band by banded Cholesky and solves the k x k Schur complement densely; otherwise
    SuperLU. Raises LinAlgError / RuntimeError when A is not positive definite / singular.
    """
    A = sp.csc_matrix(A)
    n = A.shape[0]
    k = _arrow_border(A, _MAX_BAND)
    if (n - k) * (k + 1) > _MAX_DENSE or n - k < 4 * _MAX_BAND:
        return splu(A, permc_spec=_PERMC).solve(g)
    B = A[k:, k:].tocoo()
    upper = B.row <= B.col
    ab = np.zeros((_MAX_BAND + 1, n - k))
    ab[_MAX_BAND + B.row[upper] - B.col[upper], B.col[upper]] = B.data[upper]
    Ct = A[:k, k:].tocsr()            # the border's coupling to the band (sparse: C^T = A[:k, k:])
    rhs, ok = band_cholesky_solve(ab, np.column_stack([Ct.T.toarray(), g[k:]]))
    if not ok:
        raise LinAlgError("solve_spd: the matrix is not positive definite")
    if k == 0:
        return rhs[:, 0]
    BinvC, Binvg = rhs[:, :k], rhs[:, k]
    S = A[:k, :k].toarray() - Ct @ BinvC
    x1 = cho_solve(cho_factor(S), g[:k] - Ct @ Binvg)
    return np.concatenate([x1, Binvg - BinvC @ x1])


def _sparse_lm(fun, jac, x0: np.ndarray, robust_rows: np.ndarray, delta: float, max_iterations: int,
               tolerance: float) -> np.ndarray:
    """Levenberg-Marquardt on the normal equations (J^T W J + lam D) dx = -J^T W f, sparse LU."""
    x = x0.copy()
    f = fun(x)
    cost, w = _huber(f, robust_rows, delta)
    lam = 1e-4
    n = len(x)
    for _ in range(max_iterations):
        J = jac(x)
        JW = J.T.multiply(w).tocsr() if robust_rows.any() else J.T.tocsr()
        A = (JW @ J).tocsc()
        g = JW @ f
        if np.max(np.abs(g)) <= tolerance * max(1.0, cost):
            break
        d = A.diagonal()
        d = np.maximum(d, 1e-12 * max(1.0, d.max()))
        while True:
            try:
                dx = -solve_spd(A + sp.diags(lam * d, format="csc"), g)
            except (RuntimeError, LinAlgError):          # singular: more damping
                lam *= 10.0
                if lam > 1e12:
                    return x
                continue
            xt = x + dx
            ft = fun(xt)
            ct, wt = _huber(ft, robust_rows, delta)
            if ct < cost:
                break
            lam *= 10.0
            if lam > 1e12:
                return x
        rel = (cost - ct) / max(cost, 1e-300)
        x, f, cost, w = xt, ft, ct, wt
        lam = max(lam * 0.1, 1e-10)
        if rel < tolerance or np.max(np.abs(dx)) < tolerance * (1.0 + np.max(np.abs(x))):
            break
    return x
