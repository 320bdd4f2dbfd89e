"""Banded Cholesky solve with many right-hand sides (the band part of sparse pose adjustment).

band_cholesky_solve: compiled; band_cholesky_solve_ref: scipy's LAPACK banded Cholesky
(pbtrf/pbtrs), for tests. LAPACK solves one right-hand side at a time, which for a band of
5 and 60 right-hand sides is memory bound; here every row update runs over all of them.

Storage (LAPACK's upper form): ab (u+1, n) holds A[i, j], i <= j <= i+u, at ab[u+i-j, j].
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.linalg import cho_solve_banded, cholesky_banded

__all__ = ["band_cholesky_solve", "band_cholesky_solve_ref"]


@njit(cache=True, nogil=True)
def band_cholesky_solve(ab, rhs):
    """x (n, m) with A x = rhs for the symmetric positive definite band matrix A given by ab
    (u+1, n) and rhs (n, m). Returns (x, ok); ok False (x undefined) when A is not positive
    definite."""
    u = ab.shape[0] - 1
    n = ab.shape[1]
    m = rhs.shape[1]
    U = ab.copy()                     # A = U^T U, U upper with the same band
    for j in range(n):
        for i in range(max(0, j - u), j + 1):
            s = U[u + i - j, j]
            for k in range(max(0, j - u), i):
                s -= U[u + k - i, i] * U[u + k - j, j]
            if i < j:
                U[u + i - j, j] = s / U[u, i]
            else:
                if not s > 0.0:
                    return rhs.copy(), False
                U[u, j] = math.sqrt(s)
    x = rhs.copy()
    for i in range(n):                # U^T y = rhs
        for k in range(max(0, i - u), i):
            f = U[u + k - i, i]
            for c in range(m):
                x[i, c] -= f * x[k, c]
        d = U[u, i]
        for c in range(m):
            x[i, c] /= d
    for i in range(n - 1, -1, -1):    # U x = y
        for k in range(i + 1, min(n, i + u + 1)):
            f = U[u + i - k, k]
            for c in range(m):
                x[i, c] -= f * x[k, c]
        d = U[u, i]
        for c in range(m):
            x[i, c] /= d
    return x, True


def band_cholesky_solve_ref(ab: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, bool]:
    """Reference: LAPACK through scipy.linalg."""
    try:
        chol = cholesky_banded(ab, lower=False)
    except np.linalg.LinAlgError:
        return np.array(rhs, dtype=np.float64), False
    return cho_solve_banded((chol, False), rhs), True
