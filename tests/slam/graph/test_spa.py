"""Normal-equation kernels of sparse pose adjustment against their numpy references, and the
solver built on them against the sparse product it replaces."""
import numpy as np
import pytest
import scipy.sparse as sp

from slam.graph._spa_kernel import (arrow_border, arrow_parts, arrow_parts_ref, border_products, normal_blocks,
                                    normal_blocks_ref)
from slam.graph.optimize import Constraints, _jacobian, _jacobian_values, _NormalEquations


def _problem(rng, n_sub=4, n_nodes=40, n_loops=12):
    """Submaps first, then nodes in time order: each node seen from the submap of its time
    and its neighbour, consecutive nodes chained, a few loop closures; pose 0 fixed."""
    P = n_sub + n_nodes
    poses = np.column_stack([rng.uniform(-5, 5, (P, 2)), rng.uniform(-3, 3, P)])
    i, j = [], []
    for n in range(n_nodes):
        s = min(n * n_sub // n_nodes, n_sub - 1)
        for t in {s, min(s + 1, n_sub - 1)}:
            i.append(t); j.append(n_sub + n)
    for n in range(n_nodes - 1):
        i.append(n_sub + n); j.append(n_sub + n + 1)
    for _ in range(n_loops):
        i.append(int(rng.integers(n_sub))); j.append(n_sub + int(rng.integers(n_nodes)))
    k = len(i)
    c = Constraints(np.array(i), np.array(j), rng.normal(0, 1, (k, 3)), rng.uniform(1, 100, k),
                    rng.uniform(1, 100, k), np.arange(k) >= k - n_loops)
    fixed = np.zeros(P, bool)
    fixed[0] = True
    free_col = -np.ones(P, np.int64)
    free_col[~fixed] = np.arange(P - 1)
    return poses, c, free_col, P - 1


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_normal_blocks_match_reference(seed):
    rng = np.random.default_rng(seed)
    poses, c, free_col, n_free = _problem(rng)
    ne = _NormalEquations(c, free_col, n_free, True)
    jac = _jacobian_values(poses, c)
    w, f = rng.uniform(0.2, 1.0, 3 * len(c.i)), rng.normal(size=3 * len(c.i))
    got = normal_blocks(jac, ne.idx, w, f, n_free, len(ne.pair_lo))
    ref = normal_blocks_ref(jac, ne.idx, w, f, n_free, len(ne.pair_lo))
    for a, b in zip(got, ref):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_normal_blocks_equal_the_sparse_product_bit_for_bit(seed):
    """The blocks sum their terms in the order of scipy's J^T W J, so the arrow parts are the
    very numbers the sparse product gives."""
    rng = np.random.default_rng(10 + seed)
    poses, c, free_col, n_free = _problem(rng)
    ne = _NormalEquations(c, free_col, n_free, True)
    w, f = rng.uniform(0.2, 1.0, 3 * len(c.i)), rng.normal(size=3 * len(c.i))
    J = _jacobian(poses, c, free_col, n_free)
    JW = J.T.multiply(w).tocsr()
    A = (JW @ J).toarray()
    diag, off, g = normal_blocks(_jacobian_values(poses, c), ne.idx, w, f, n_free, len(ne.pair_lo))
    assert np.array_equal(g, JW @ f)
    k = arrow_border(off, ne.pair_lo, ne.pair_hi, 5)
    ab, Ct, S, d = arrow_parts(diag, off, ne.pair_lo, ne.pair_hi, k, 5)
    k_ref, ab_ref, Ct_ref, S_ref, d_ref = arrow_parts_ref(np.triu(A) + np.triu(A, 1).T, 5)
    assert k == k_ref > 0
    assert np.array_equal(ab, ab_ref) and np.array_equal(Ct, Ct_ref) and np.array_equal(d, d_ref)
    assert np.array_equal(np.triu(S), np.triu(S_ref))


@pytest.mark.kernel
def test_border_products_match_dense_products(rng):
    n, k = 50, 6
    Ct = np.zeros((n, k + 1))
    for i in range(k):
        rows = rng.choice(n, 8, replace=False)
        Ct[rows, i] = rng.normal(size=8)
    X = rng.normal(size=(n, k + 1))
    P, v = border_products(Ct, X)
    full = Ct[:, :k].T @ X
    np.testing.assert_allclose(np.triu(P), np.triu(full[:, :k]), atol=1e-12)
    np.testing.assert_allclose(P, P.T)
    np.testing.assert_allclose(v, full[:, k], atol=1e-12)


def test_normal_equations_solve_like_the_sparse_system(rng):
    poses, c, free_col, n_free = _problem(rng, n_nodes=60)
    ne = _NormalEquations(c, free_col, n_free, True)
    w, f = rng.uniform(0.2, 1.0, 3 * len(c.i)), rng.normal(size=3 * len(c.i))
    system, g, d = ne(poses, w, f)
    damping = 1e-3 * d + 1e-6
    J = _jacobian(poses, c, free_col, n_free)
    A = (J.T.multiply(w).tocsr() @ J) + sp.diags(damping)
    np.testing.assert_allclose(system.solve(damping, g), sp.linalg.spsolve(A.tocsc(), g), rtol=1e-8, atol=1e-10)
