"""Banded Cholesky kernel against LAPACK, and solve_spd against a sparse direct solve."""
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.linalg import LinAlgError
from scipy.sparse.linalg import spsolve

from slam.graph._band_kernel import band_cholesky_solve, band_cholesky_solve_ref
from slam.graph.optimize import solve_spd


def _band_spd(rng, n, u):
    """A random symmetric positive definite matrix of half-bandwidth u (dense) and its
    LAPACK upper band storage."""
    M = np.zeros((n, n))
    for d in range(1, u + 1):
        v = rng.normal(size=n - d)
        M += np.diag(v, d) + np.diag(v, -d)
    M += np.diag(np.abs(M).sum(axis=1) + rng.uniform(0.5, 2.0, n))   # diagonally dominant
    ab = np.zeros((u + 1, n))
    for j in range(n):
        for i in range(max(0, j - u), j + 1):
            ab[u + i - j, j] = M[i, j]
    return M, ab


@pytest.mark.kernel
@pytest.mark.parametrize("n, u, m", [(1, 0, 1), (7, 2, 3), (60, 5, 9), (200, 5, 1)])
def test_band_cholesky_matches_lapack_and_solves(n, u, m):
    rng = np.random.default_rng(n)
    M, ab = _band_spd(rng, n, u)
    rhs = rng.normal(size=(n, m))
    x, ok = band_cholesky_solve(ab, rhs)
    x_ref, ok_ref = band_cholesky_solve_ref(ab, rhs)
    assert ok and ok_ref
    np.testing.assert_allclose(x, x_ref, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(M @ x, rhs, atol=1e-9)


@pytest.mark.kernel
def test_band_cholesky_reports_an_indefinite_matrix():
    M, ab = _band_spd(np.random.default_rng(3), 30, 3)
    ab[3, 17] = -1.0                       # a negative pivot
    assert band_cholesky_solve(ab, np.ones((30, 2)))[1] is False
    assert band_cholesky_solve_ref(ab, np.ones((30, 2)))[1] is False


def _arrow(rng, n_band, k, u=5):
    """SPD arrow matrix: k border unknowns first, then a band of half-width u, the border
    coupled to a few random band unknowns (as submaps to the nodes that see them)."""
    M, _ = _band_spd(rng, n_band, u)
    n = k + n_band
    A = np.zeros((n, n))
    A[k:, k:] = M
    for b in range(k):
        rows = k + rng.choice(n_band, size=6, replace=False)
        A[b, rows] = A[rows, b] = rng.normal(size=6) * 0.3
    A[:k, :k] += np.diag(np.abs(A[:k]).sum(axis=1) + 1.0)
    return sp.csc_matrix(A)


@pytest.mark.kernel
@pytest.mark.parametrize("k", [0, 4, 30])
def test_solve_spd_arrow_matches_sparse_solve(k):
    rng = np.random.default_rng(k)
    A = _arrow(rng, 120, k)
    g = rng.normal(size=A.shape[0])
    np.testing.assert_allclose(solve_spd(A, g), spsolve(A, g), rtol=1e-9, atol=1e-12)


def test_solve_spd_general_matrix_goes_to_the_sparse_lu():
    rng = np.random.default_rng(5)
    n = 80
    R = sp.random(n, n, density=0.1, random_state=6)
    A = sp.csc_matrix(R @ R.T + sp.identity(n) * 2.0)    # entries far from the diagonal everywhere
    g = rng.normal(size=n)
    np.testing.assert_allclose(solve_spd(A, g), spsolve(A, g), rtol=1e-9, atol=1e-12)


@pytest.mark.kernel
def test_solve_spd_raises_on_an_indefinite_band():
    A = _arrow(np.random.default_rng(1), 60, 3).tolil()
    A[40, 40] = -50.0
    with pytest.raises(LinAlgError):
        solve_spd(sp.csc_matrix(A), np.ones(63))


def test_solve_spd_hands_large_borders_to_the_sparse_lu(monkeypatch):
    import slam.graph.optimize as opt
    calls = []
    real = opt.splu

    def spy(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(opt, "splu", spy)
    rng = np.random.default_rng(9)
    A = _arrow(rng, 120, 30)
    g = rng.normal(size=A.shape[0])
    opt.solve_spd(A, g)
    assert calls == []                               # the arrow path
    monkeypatch.setattr(opt, "_MAX_DENSE", 120 * 31 - 1)
    np.testing.assert_allclose(opt.solve_spd(A, g), spsolve(A, g), rtol=1e-9, atol=1e-12)
    assert calls == [1]                              # too big a dense block: SuperLU
