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
to 1e-13). The solver assembles J^T W J of an arrow directly in that form, from one 3x3
block per pose and per coupled pair (slam.graph._spa_kernel), summing every entry in the
order of the sparse product, so it gives the same numbers without building J.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import LinAlgError, cho_factor, cho_solve
from scipy.sparse.linalg import splu

from slam.graph._band_kernel import band_cholesky_solve
from slam.graph._spa_kernel import (_COMP, _POSE, _ROW, arrow_border, arrow_parts, border_products,
                                     normal_blocks)
from slam.pose import wrap_angle

__all__ = ["Constraints", "spa_residuals", "optimize_poses", "solve_spd"]


@dataclass(frozen=True, eq=False)
class Constraints:
    """Relative-pose constraints between pose variables of one problem.

    i, j: (C,) int indices into the stacked variable array (submaps then nodes, or any
    order the caller chooses); z: (C, 3) pose of j in the frame of i (x, y m, yaw rad);
    w_t, w_r: (C,) translation (1/m) and rotation (1/rad) weights; robust: (C,) bool, Huber
    loss on this constraint (loop closures).
    axis, w_t_across: an anisotropic translation weight: w_t along the direction `axis` (C,)
    rad from z's x axis, w_t_across (C,) across it (a corridor match pins only its side
    position). None: axis 0, w_t_across = w_t (isotropic).
    """

    i: np.ndarray
    j: np.ndarray
    z: np.ndarray
    w_t: np.ndarray
    w_r: np.ndarray
    robust: np.ndarray
    axis: np.ndarray | None = None
    w_t_across: np.ndarray | None = None

    def __post_init__(self):
        n = len(np.asarray(self.i))
        if self.axis is None:
            object.__setattr__(self, "axis", np.zeros(n))
        if self.w_t_across is None:
            object.__setattr__(self, "w_t_across", np.asarray(self.w_t))
        for name, shape in (("j", (n,)), ("z", (n, 3)), ("w_t", (n,)), ("w_r", (n,)), ("robust", (n,)),
                            ("axis", (n,)), ("w_t_across", (n,))):
            arr = np.asarray(getattr(self, name))
            if arr.shape != shape:
                raise ValueError(f"Constraints.{name}: expected shape {shape}, got {arr.shape}")


def spa_residuals(poses: np.ndarray, c: Constraints) -> np.ndarray:
    """(C, 3) weighted errors of the constraints at `poses` ((P, 3) global poses): along
    each constraint's axis, across it, in yaw."""
    return _residuals(poses, c, *_axis_cos_sin(c))


def _axis_cos_sin(c: Constraints) -> tuple[np.ndarray, np.ndarray]:
    """Cosines and sines (C,) of each constraint's first residual axis in the frame of i."""
    a = c.z[:, 2] + c.axis
    return np.cos(a), np.sin(a)


def _residuals(poses: np.ndarray, c: Constraints, ct: np.ndarray, st: np.ndarray) -> np.ndarray:
    """spa_residuals with the axes' cosines and sines ct, st (C,) given (_axis_cos_sin: the
    solver evaluates the residuals of one problem many times)."""
    a, b = poses[c.i], poses[c.j]
    # relative(a, b) = compose(inverse(a), b), the operations of slam.pose on arrays
    ca, sa = np.cos(a[:, 2]), np.sin(a[:, 2])
    ix = -ca * a[:, 0] - sa * a[:, 1]
    iy = sa * a[:, 0] - ca * a[:, 1]
    ith = wrap_angle(-a[:, 2])
    cb, sb = np.cos(ith), np.sin(ith)
    # Error expressed in the measured frame z, as Cartographer's ComputeUnscaledError.
    dx = ix + cb * b[:, 0] - sb * b[:, 1] - c.z[:, 0]
    dy = iy + sb * b[:, 0] + cb * b[:, 1] - c.z[:, 1]
    out = np.empty((len(c.i), 3))
    out[:, 0] = c.w_t * (ct * dx + st * dy)
    out[:, 1] = c.w_t_across * (-st * dx + ct * dy)
    out[:, 2] = c.w_r * wrap_angle(wrap_angle(ith + b[:, 2]) - c.z[:, 2])
    return out


def _jacobian_values(poses: np.ndarray, c: Constraints) -> np.ndarray:
    """(C, 12) the nonzero entries of d(spa_residuals)/d(poses) of each constraint, in the
    layout of slam.graph._spa_kernel: rows 0 and 1 over (x_j, y_j, x_i, y_i, yaw_i), row 2
    over (yaw_j, yaw_i)."""
    pi, pj = poses[c.i], poses[c.j]
    th = pi[:, 2]
    dtx = pj[:, 0] - pi[:, 0]
    dty = pj[:, 1] - pi[:, 1]
    # ex = R(a)^T R(th_i)^T (t_j - t_i) - ... with a = z_th + axis; R(a)^T R(th_i)^T = R(th_i + a)^T
    a = th + c.z[:, 2] + c.axis
    ca, sa = np.cos(a), np.sin(a)
    wt, wc, wr = c.w_t, c.w_t_across, c.w_r
    out = np.empty((len(c.i), 12))
    # d ex / d t_j = w_t * [ca, sa]; d ey / d t_j = w_t_across * [-sa, ca]; d/d th_i of
    # [ca*dtx + sa*dty, -sa*dtx + ca*dty]
    out[:, 0], out[:, 1], out[:, 2], out[:, 3] = wt * ca, wt * sa, -wt * ca, -wt * sa
    out[:, 4] = wt * (-sa * dtx + ca * dty)
    out[:, 5], out[:, 6], out[:, 7], out[:, 8] = -wc * sa, wc * ca, wc * sa, -wc * ca
    out[:, 9] = wc * (-ca * dtx - sa * dty)
    out[:, 10], out[:, 11] = wr, -wr
    return out


def _jacobian(poses: np.ndarray, c: Constraints, free_col: np.ndarray, n_free: int) -> sp.csr_matrix:
    """Sparse d(residuals)/d(free variables) of spa_residuals, rows 3k..3k+2 for constraint k."""
    jv = _jacobian_values(poses, c)
    n = len(c.i)
    var = np.stack([free_col[c.j], free_col[c.i]], axis=1)[:, _POSE]          # (C, 12)
    ok = var >= 0
    rows = (3 * np.arange(n)[:, None] + _ROW[None, :])[ok]
    cols = (3 * var + _COMP[None, :])[ok]
    return sp.csr_matrix((jv[ok], (rows, cols)), shape=(3 * n, 3 * n_free))


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

    ct, st = _axis_cos_sin(c)

    def fun(x):
        return _residuals(current(x), c, ct, st).reshape(-1)

    normal = _NormalEquations(c, free_col, len(free_idx), robust_rows.any())
    x = _sparse_lm(fun, lambda x, w, f: normal(current(x), w, f), x0, robust_rows, huber_scale,
                   max_iterations, tolerance)
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


def _use_arrow(n: int, k: int) -> bool:
    return (n - k) * (k + 1) <= _MAX_DENSE and n - k >= 4 * _MAX_BAND


def solve_spd(A: sp.spmatrix, g: np.ndarray) -> np.ndarray:
    """x with A x = g for a sparse symmetric positive definite A.

    When A is an arrow (a small border of k leading unknowns, the rest banded), it eliminates
    the band by banded Cholesky and solves the k x k Schur complement densely; otherwise
    SuperLU. Raises LinAlgError / RuntimeError when A is not positive definite / singular.
    """
    A = sp.csc_matrix(A)
    n = A.shape[0]
    k = _arrow_border(A, _MAX_BAND)
    if not _use_arrow(n, k):
        return splu(A, permc_spec=_PERMC).solve(g)
    B = A[k:, k:].tocoo()
    upper = B.row <= B.col
    ab = np.zeros((_MAX_BAND + 1, n - k))
    ab[_MAX_BAND + B.row[upper] - B.col[upper], B.col[upper]] = B.data[upper]
    Ct = np.zeros((n - k, k + 1))
    Ct[:, :k] = A[:k, k:].T.toarray()
    return _solve_arrow(ab, Ct, A[:k, :k].toarray(), g)


def _solve_arrow(ab: np.ndarray, Ct: np.ndarray, S: np.ndarray, g: np.ndarray) -> np.ndarray:
    """x with A x = g for the arrow A of border block S (k, k) (upper triangle read), coupling
    Ct[:, :k] (n-k, k) = A[k:, :k] and band ab (LAPACK upper storage of A[k:, k:]); Ct's last
    column is overwritten with g[k:]."""
    k = len(S)
    Ct[:, k] = g[k:]
    rhs, ok = band_cholesky_solve(ab, Ct)
    if not ok:
        raise LinAlgError("solve_spd: the matrix is not positive definite")
    if k == 0:
        return rhs[:, 0]
    BinvC, Binvg = rhs[:, :k], rhs[:, k]
    P, v = border_products(Ct, rhs)
    x1 = cho_solve(cho_factor(S - P), g[:k] - v)
    return np.concatenate([x1, Binvg - BinvC @ x1])


class _NormalEquations:
    """J^T W J and J^T W f of one problem at given poses: as arrow blocks (slam.graph._spa_kernel)
    or, for a graph that is no arrow, as a sparse matrix."""

    def __init__(self, c: Constraints, free_col: np.ndarray, n_free: int, robust: bool):
        self.c, self.free_col, self.n_free, self.robust = c, free_col, n_free, robust
        fi, fj = free_col[c.i], free_col[c.j]
        both = (fi >= 0) & (fj >= 0)
        lo, hi = np.minimum(fi, fj)[both], np.maximum(fi, fj)[both]
        keys, pair = np.unique(lo * n_free + hi, return_inverse=True)
        self.idx = np.stack([fi, fj, -np.ones_like(fi)], axis=1)
        self.idx[both, 2] = pair.reshape(-1)
        self.pair_lo, self.pair_hi = keys // max(n_free, 1), keys % max(n_free, 1)
        # a constraint of a pose to itself puts two entries in one Jacobian cell
        self.blocks = bool(np.all(c.i != c.j))

    def __call__(self, poses: np.ndarray, w: np.ndarray, f: np.ndarray):
        """(system with .solve(damping (n,), g) -> x, g (n,), diagonal (n,)) at poses (P, 3),
        IRLS weights w and residuals f (3C,)."""
        if self.blocks:
            diag, off, g = normal_blocks(_jacobian_values(poses, self.c), self.idx, w, f, self.n_free,
                                         len(self.pair_lo))
            k = arrow_border(off, self.pair_lo, self.pair_hi, _MAX_BAND)
            if _use_arrow(3 * self.n_free, k):
                ab, Ct, S, d = arrow_parts(diag, off, self.pair_lo, self.pair_hi, k, _MAX_BAND)
                return _ArrowSystem(ab, Ct, S), g, d
        J = _jacobian(poses, self.c, self.free_col, self.n_free)
        JW = J.T.multiply(w).tocsr() if self.robust else J.T.tocsr()
        A = (JW @ J).tocsc()
        return _SparseSystem(A), JW @ f, A.diagonal()


class _ArrowSystem:
    def __init__(self, ab: np.ndarray, Ct: np.ndarray, S: np.ndarray):
        self.ab, self.Ct, self.S = ab, Ct, S

    def solve(self, damping: np.ndarray, g: np.ndarray) -> np.ndarray:
        """x with (A + diag(damping)) x = g."""
        k = len(self.S)
        ab = self.ab.copy()
        ab[_MAX_BAND] += damping[k:]
        S = self.S.copy()
        S[np.diag_indices(k)] += damping[:k]
        return _solve_arrow(ab, self.Ct, S, g)


class _SparseSystem:
    def __init__(self, A: sp.csc_matrix):
        self.A = A

    def solve(self, damping: np.ndarray, g: np.ndarray) -> np.ndarray:
        """x with (A + diag(damping)) x = g."""
        return solve_spd(self.A + sp.diags(damping, format="csc"), g)


def _sparse_lm(fun, normal, x0: np.ndarray, robust_rows: np.ndarray, delta: float, max_iterations: int,
               tolerance: float) -> np.ndarray:
    """Levenberg-Marquardt on the normal equations (J^T W J + lam D) dx = -J^T W f;
    normal(x, w, f) -> (system, J^T W f, diagonal of J^T W J)."""
    x = x0.copy()
    f = fun(x)
    cost, w = _huber(f, robust_rows, delta)
    lam = 1e-4
    for _ in range(max_iterations):
        system, g, d = normal(x, w, f)
        if np.max(np.abs(g)) <= tolerance * max(1.0, cost):
            break
        d = np.maximum(d, 1e-12 * max(1.0, d.max()))
        while True:
            try:
                dx = -system.solve(lam * d, g)
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
