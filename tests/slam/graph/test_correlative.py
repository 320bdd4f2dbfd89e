"""Correlative scan matching kernels: precomputation grids, branch and bound == brute force."""
import numpy as np
import pytest

from slam.graph._correlative_kernel import (best_candidate_ref, bnb_margin, bnb_search, discretize_rotations,
                                       discretize_rotations_ref, max_grids, max_grids_ref,
                                       score_candidates, score_candidates_ref)


def _problem(rng, rows=40, cols=50, K=5, P=30, w=9):
    grid = rng.random((rows, cols)).astype(np.float32) ** 3      # few high cells, no ties
    cells = np.stack([rng.integers(-3, cols + 3, (K, P)), rng.integers(-3, rows + 3, (K, P))],
                     axis=2).astype(np.int32)
    return grid, cells, w


def _bnb(grid, depth, cells, wx, wy, min_score, ex_x=0, ex_y=0, ex_r=-1, extra=0):
    """bnb_search on the max grids of `grid` with the margin it needs (plus `extra`)."""
    m = bnb_margin(depth, wx, wy) + extra
    return bnb_search(max_grids(grid, depth, m), m, cells, wx, wy, min_score, ex_x, ex_y, ex_r)


@pytest.mark.kernel
@pytest.mark.parametrize("depth", [0, 1, 3])
def test_max_grids_matches_reference(rng, depth):
    grid = rng.random((13, 17)).astype(np.float32)
    np.testing.assert_array_equal(max_grids(grid, depth, 0), max_grids_ref(grid, depth))
    m = 5
    np.testing.assert_array_equal(max_grids(grid, depth, m),
                                  np.pad(max_grids_ref(grid, depth), ((0, 0), (m, m), (m, m))))


@pytest.mark.kernel
def test_discretize_rotations_matches_reference(rng):
    pts = rng.normal(0, 2.0, (200, 2))
    yaws = 0.7 + np.arange(-20, 21) * 0.013
    args = (pts, 1.234, -0.56, yaws, -3.05, -2.95, 0.05)
    cells = discretize_rotations(*args)
    assert cells.dtype == np.int32 and cells.shape == (41, 200, 2)
    np.testing.assert_array_equal(cells, discretize_rotations_ref(*args))


@pytest.mark.kernel
def test_score_candidates_matches_reference(rng):
    grid, cells, w = _problem(rng)
    np.testing.assert_allclose(score_candidates(grid.astype(np.float64), cells, w, w - 2),
                               score_candidates_ref(grid.astype(np.float64), cells, w, w - 2), atol=1e-12)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("depth", [1, 2, 4, 7])   # 7: blocks far larger than the window
def test_branch_and_bound_equals_brute_force(seed, depth):
    rng = np.random.default_rng(seed)
    grid, cells, w = _problem(rng, w=5 + seed)
    k, dx, dy, s = _bnb(grid, depth, cells, w, w + 1, 0.0, extra=seed % 3)
    rk, rdx, rdy, rs = best_candidate_ref(grid, cells, w, w + 1)
    assert (k, dx, dy) == (rk, rdx, rdy)
    assert s == pytest.approx(rs, rel=1e-5)


@pytest.mark.kernel
def test_branch_and_bound_respects_min_score(rng):
    grid, cells, w = _problem(rng)
    _, _, _, best = best_candidate_ref(grid, cells, w, w)
    k, *_ = _bnb(grid, 3, cells, w, w, best + 1e-3)
    assert k == -1
    k, *_ = _bnb(grid, 3, cells, w, w, best - 1e-3)
    assert k >= 0


@pytest.mark.kernel
def test_branch_and_bound_scores_points_far_off_the_grid_as_zero(rng):
    grid, cells, w = _problem(rng)
    far = cells.copy()
    far[:, ::3, 0] += 10_000                  # a third of the points far beyond the grid
    far[:, 1::3, 1] -= 10_000
    k, dx, dy, s = _bnb(grid, 3, far, w, w, 0.0)
    rk, rdx, rdy, rs = best_candidate_ref(grid, far, w, w)
    assert (k, dx, dy) == (rk, rdx, rdy)
    assert s == pytest.approx(rs, rel=1e-5)


@pytest.mark.kernel
def test_branch_and_bound_refuses_a_margin_too_small(rng):
    grid, cells, w = _problem(rng)
    m = bnb_margin(3, w, w) - 1
    with pytest.raises(ValueError):
        bnb_search(max_grids(grid, 3, m), m, cells, w, w, 0.0, 0, 0, -1)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(6))
def test_branch_and_bound_with_exclusion_equals_brute_force(seed):
    rng = np.random.default_rng(100 + seed)
    grid, cells, w = _problem(rng, w=8)
    k0, dx0, dy0, _ = best_candidate_ref(grid, cells, w, w)
    ex = (dx0, dy0, 1 + seed % 3)
    k, dx, dy, s = _bnb(grid, 3, cells, w, w, 0.0, *ex)
    rk, rdx, rdy, rs = best_candidate_ref(grid, cells, w, w, exclude=ex)
    assert (k, dx, dy) == (rk, rdx, rdy)
    assert max(abs(dx - dx0), abs(dy - dy0)) > ex[2]
    assert s == pytest.approx(rs, rel=1e-5)
