"""Normal equations of sparse pose adjustment (Konolige et al. 2010), compiled.

Each constraint c couples two poses i and j with three residual rows; its Jacobian has 12
entries (`jac` (C, 12)): rows 0 and 1 over (x_j, y_j, x_i, y_i, yaw_i) at [0:5] and [5:10],
row 2 over (yaw_j, yaw_i) at [10:12]. The unknowns are the free poses, three columns each;
`idx` (C, 3) int64 holds the free index of i and of j (-1: held fixed) and the index of the
(lower, higher) free pair the constraint couples (-1 if either is fixed).

- normal_blocks: the upper triangle of A = J^T W J as 3x3 blocks (one per free pose on the
  diagonal, one per coupled pair off it) and g = J^T W f. Every entry sums its terms
  (J[k, a] w[k]) J[k, b] over the residual rows k in ascending order, the order of a sparse
  product of the same matrices.
- arrow_border / arrow_parts: A as an arrow (slam.graph.optimize.solve_spd): the smallest
  border k outside which A is a band, the band in LAPACK's upper storage, the border's
  coupling to the band and the border block.
- border_products: the products of the border's coupling C with the band's solutions that
  the Schur complement needs, over the nonzero entries of each row of C in column order (the
  order of a compressed-row sparse product).

*_ref: numpy statements of the same for the tests.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["normal_blocks", "arrow_border", "arrow_parts", "border_products", "normal_blocks_ref",
           "arrow_parts_ref"]

# (residual row, pose (0 = j, 1 = i), component) of each of the 12 Jacobian entries
_ROW = np.array([0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 2, 2], np.int64)
_POSE = np.array([0, 0, 1, 1, 1, 0, 0, 1, 1, 1, 0, 1], np.int64)
_COMP = np.array([0, 1, 0, 1, 2, 0, 1, 0, 1, 2, 2, 2], np.int64)
_ROW_START = np.array([0, 5, 10, 12], np.int64)


@njit(cache=True, nogil=True)
def normal_blocks(jac, idx, w, f, n_free, n_pairs):
    """(diag (n_free, 3, 3), off (n_pairs, 3, 3), g (3 n_free,)): diag[p, u, v] = A[3p+u, 3p+v]
    for u <= v (below: 0), off[q, u, v] = A[3 lo+u, 3 hi+v] of pair q = (lo, hi); w, f (3C,)
    residual weights and residuals."""
    diag = np.zeros((n_free, 3, 3))
    off = np.zeros((n_pairs, 3, 3))
    g = np.zeros(3 * n_free)
    var = np.empty(2, np.int64)
    for c in range(jac.shape[0]):
        var[0] = idx[c, 1]
        var[1] = idx[c, 0]
        q = idx[c, 2]
        for r in range(3):
            k = 3 * c + r
            wk = w[k]
            for ea in range(_ROW_START[r], _ROW_START[r + 1]):
                va = var[_POSE[ea]]
                if va < 0:
                    continue
                ua = _COMP[ea]
                jw = jac[c, ea] * wk
                g[3 * va + ua] += jw * f[k]
                for eb in range(_ROW_START[r], _ROW_START[r + 1]):
                    vb = var[_POSE[eb]]
                    if vb < 0:
                        continue
                    ub = _COMP[eb]
                    if va == vb:
                        if ua <= ub:
                            diag[va, ua, ub] += jw * jac[c, eb]
                    elif va < vb:
                        off[q, ua, ub] += jw * jac[c, eb]
    return diag, off, g


@njit(cache=True, nogil=True)
def arrow_border(off, pair_lo, pair_hi, band):
    """Smallest k such that no nonzero entry of A[k:, k:] lies farther than `band` from the
    diagonal (off, pair_lo, pair_hi: the off-diagonal blocks and their free poses)."""
    k = 0
    for q in range(off.shape[0]):
        for u in range(3):
            a = 3 * pair_lo[q] + u
            for v in range(3):
                b = 3 * pair_hi[q] + v
                if b - a > band and off[q, u, v] != 0.0 and a + 1 > k:
                    k = a + 1
    return k


@njit(cache=True, nogil=True)
def arrow_parts(diag, off, pair_lo, pair_hi, k, band):
    """(ab (band+1, n-k) upper band storage of A[k:, k:], Ct (n-k, k+1) = [A[:k, k:]^T | 0]
    (the band solve's right-hand sides, the last column left for the gradient), S (k, k) =
    A[:k, :k] (both triangles), d (n,) the diagonal of A) of A given by its blocks; k from
    arrow_border."""
    n_diag = 9 * diag.shape[0]
    n = 3 * diag.shape[0]
    ab = np.zeros((band + 1, n - k))
    Ct = np.zeros((n - k, k + 1))
    S = np.zeros((k, k))
    d = np.empty(n)
    dv = diag.reshape(-1)
    ov = off.reshape(-1)
    # one loop over the entries of all blocks (a helper per entry would cost more than it does)
    for e in range(n_diag + ov.shape[0]):
        if e < n_diag:
            lo = hi = e // 9
            value = dv[e]
        else:
            lo, hi = pair_lo[(e - n_diag) // 9], pair_hi[(e - n_diag) // 9]
            value = ov[e - n_diag]
        a = 3 * lo + (e % 9) // 3
        b = 3 * hi + e % 3
        if a > b:                 # below the diagonal of a diagonal block
            continue
        if a == b:
            d[a] = value
        if a >= k:
            if value != 0.0:      # far entries of the band part are zero (arrow_border)
                ab[band + a - b, b - k] = value
        elif b >= k:
            Ct[b - k, a] = value
        else:
            S[a, b] = value
            S[b, a] = value
    return ab, Ct, S, d


@njit(cache=True, nogil=True)
def border_products(Ct, X):
    """(P (k, k), v (k,)) of the coupling C = Ct[:, :k]^T (Ct (n, k+1), from arrow_parts) and
    X (n, k+1): P = C @ X[:, :k] on and above the diagonal (mirrored below: the Schur
    complement is symmetric and only its upper triangle is factorised), v = C @ X[:, k]; each
    entry sums over the nonzero entries of its row of C in column order, as a compressed-row
    sparse product."""
    n = Ct.shape[0]
    k = Ct.shape[1] - 1
    P = np.zeros((k, k))
    v = np.zeros(k)
    for j in range(n):
        for i in range(k):
            a = Ct[j, i]
            if a != 0.0:
                for c in range(i, k):
                    P[i, c] += a * X[j, c]
                v[i] += a * X[j, k]
    for i in range(k):
        for c in range(i):
            P[i, c] = P[c, i]
    return P, v


def normal_blocks_ref(jac, idx, w, f, n_free, n_pairs):
    """Reference of normal_blocks: a dense Jacobian, A = J^T diag(w) J, cut into blocks."""
    J = np.zeros((3 * len(jac), 3 * n_free))
    for c in range(len(jac)):
        for e in range(12):
            v = idx[c, 1 - _POSE[e]]
            if v >= 0:
                J[3 * c + _ROW[e], 3 * v + _COMP[e]] = jac[c, e]
    A = J.T @ (w[:, None] * J)
    g = J.T @ (w * f)
    diag = np.stack([np.triu(A[3 * p:3 * p + 3, 3 * p:3 * p + 3]) for p in range(n_free)]).reshape(n_free, 3, 3)
    off = np.zeros((n_pairs, 3, 3))
    for c in range(len(jac)):
        if idx[c, 2] >= 0:
            lo, hi = sorted((idx[c, 0], idx[c, 1]))
            off[idx[c, 2]] = A[3 * lo:3 * lo + 3, 3 * hi:3 * hi + 3]
    return diag, off, g


def arrow_parts_ref(A: np.ndarray, band: int):
    """Reference of arrow_border + arrow_parts from a dense symmetric A: (k, ab, Ct, S, d)."""
    n = len(A)
    rows, cols = np.nonzero(np.triu(A))
    far = cols - rows > band
    k = int(rows[far].max()) + 1 if far.any() else 0
    ab = np.zeros((band + 1, n - k))
    for s in range(band + 1):
        ab[band - s, s:] = np.diagonal(A[k:, k:], s)
    Ct = np.zeros((n - k, k + 1))
    Ct[:, :k] = A[:k, k:].T
    return k, ab, Ct, A[:k, :k].copy(), np.diagonal(A).copy()
