"""Ray insertion kernel against its numpy reference, and the update rule."""
import numpy as np
import pytest

from slam._kernels.insert import insert_rays_inplace, insert_rays_ref
from slam.occupancy import logodds

L_FREE, L_OCC = logodds(0.4), logodds(0.9)


def _random_case(seed):
    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(20, 60, 2)
    res = rng.choice([0.05, 0.1, 0.2])
    meta = np.array([rng.uniform(-2, 2), rng.uniform(-2, 2), res, rows, cols], dtype=np.float64)
    lo = rng.normal(0, 2, (rows, cols))
    lo[rng.random((rows, cols)) < 0.4] = np.nan
    origin = meta[:2] + rng.uniform(0.2, 0.8, 2) * [cols * res, rows * res]
    n = int(rng.integers(1, 200))
    ends = origin + rng.normal(0, 0.4 * max(rows, cols) * res, (n, 2))  # some leave the grid
    hit = rng.random(n) < 0.7
    return lo, meta, origin, ends, hit


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(12))
def test_kernel_matches_reference(seed):
    lo, meta, origin, ends, hit = _random_case(seed)
    ref = insert_rays_ref(lo, meta, origin, ends, hit, L_FREE, L_OCC, -4.0, 4.0)
    out = lo.copy()
    n = insert_rays_inplace(out, meta, origin, ends, hit, L_FREE, L_OCC, -4.0, 4.0)
    np.testing.assert_array_equal(np.isnan(out), np.isnan(ref))
    np.testing.assert_allclose(np.nan_to_num(out), np.nan_to_num(ref), atol=1e-12)
    assert n >= int(np.sum(np.isnan(lo) & ~np.isnan(out)))


def test_reference_leaves_input_unchanged():
    lo, meta, origin, ends, hit = _random_case(0)
    before = lo.copy()
    insert_rays_ref(lo, meta, origin, ends, hit, L_FREE, L_OCC, -4.0, 4.0)
    np.testing.assert_array_equal(np.nan_to_num(lo, nan=7), np.nan_to_num(before, nan=7))


def test_single_ray_frees_path_and_marks_end():
    lo = np.full((10, 10), np.nan)
    meta = np.array([0.0, 0.0, 1.0, 10, 10])
    insert_rays_inplace(lo, meta, np.array([0.5, 0.5]), np.array([[7.5, 0.5]]), np.array([True]),
                        -0.5, 2.0, -5.0, 5.0)
    np.testing.assert_allclose(lo[0, :7], -0.5)
    assert lo[0, 7] == 2.0
    assert np.isnan(lo[0, 8:]).all() and np.isnan(lo[1:]).all()


def test_no_return_ray_frees_its_end_cell():
    lo = np.full((10, 10), np.nan)
    meta = np.array([0.0, 0.0, 1.0, 10, 10])
    insert_rays_inplace(lo, meta, np.array([0.5, 0.5]), np.array([[0.5, 6.5]]), np.array([False]),
                        -0.5, 2.0, -5.0, 5.0)
    np.testing.assert_allclose(lo[:7, 0], -0.5)
    assert np.isnan(lo[7:, 0]).all()


def test_hit_wins_over_free_and_each_cell_once_per_scan():
    lo = np.zeros((10, 10))
    meta = np.array([0.0, 0.0, 1.0, 10, 10])
    # two rays along the same row: the second one passes through the first one's hit cell
    ends = np.array([[4.5, 0.5], [8.5, 0.5], [8.6, 0.4]])
    insert_rays_inplace(lo, meta, np.array([0.5, 0.5]), ends, np.array([True, True, True]),
                        -0.5, 2.0, -5.0, 5.0)
    assert lo[0, 4] == 2.0 and lo[0, 8] == 2.0
    np.testing.assert_allclose(lo[0, [0, 1, 2, 3, 5, 6, 7]], -0.5)


def test_clamping():
    lo = np.full((3, 3), 4.9)
    meta = np.array([0.0, 0.0, 1.0, 3, 3])
    insert_rays_inplace(lo, meta, np.array([0.5, 0.5]), np.array([[2.5, 0.5]]), np.array([True]),
                        -0.5, 2.0, -5.0, 5.0)
    assert lo[0, 2] == 5.0


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(8))
def test_kernel_matches_reference_with_free_margin(seed):
    lo, meta, origin, ends, hit = _random_case(200 + seed)
    rng = np.random.default_rng(seed)
    margin = rng.uniform(0.0, 6 * meta[2], len(ends)) * (rng.random(len(ends)) < 0.8)
    ref = insert_rays_ref(lo, meta, origin, ends, hit, L_FREE, L_OCC, -4.0, 4.0, margin)
    out = lo.copy()
    insert_rays_inplace(out, meta, origin, ends, hit, L_FREE, L_OCC, -4.0, 4.0, margin)
    np.testing.assert_array_equal(np.isnan(out), np.isnan(ref))
    np.testing.assert_allclose(np.nan_to_num(out), np.nan_to_num(ref), atol=1e-12)


@pytest.mark.kernel
def test_zero_margin_is_the_plain_update():
    lo, meta, origin, ends, hit = _random_case(7)
    plain, banded = lo.copy(), lo.copy()
    insert_rays_inplace(plain, meta, origin, ends, hit, L_FREE, L_OCC, -4.0, 4.0)
    insert_rays_inplace(banded, meta, origin, ends, hit, L_FREE, L_OCC, -4.0, 4.0, np.zeros(len(ends)))
    np.testing.assert_array_equal(np.isnan(plain), np.isnan(banded))
    np.testing.assert_array_equal(np.nan_to_num(plain), np.nan_to_num(banded))


def test_free_margin_leaves_the_noise_band_observed_but_unchanged():
    lo = np.full((3, 12), np.nan)
    lo[0, 8] = 1.0                       # mapped before: a band cell keeps its value
    meta = np.array([0.0, 0.0, 1.0, 3, 12])
    # hit at x = 10.5 (cell 10); the margin of 3.8 cells puts the last free point at x = 6.7
    insert_rays_inplace(lo, meta, np.array([0.5, 0.5]), np.array([[10.5, 0.5]]), np.array([True]),
                        -0.5, 2.0, -5.0, 5.0, np.array([3.8]))
    np.testing.assert_allclose(lo[0, :7], -0.5)        # cells 0-6 freed
    np.testing.assert_allclose(lo[0, 7:10], [0.0, 1.0, 0.0])  # band: observed, not freed
    assert lo[0, 10] == 2.0 and np.isnan(lo[0, 11])


def test_a_band_cell_another_ray_passes_through_is_freed():
    meta = np.array([0.0, 0.0, 1.0, 3, 12])
    ends = np.array([[10.5, 0.5], [11.5, 0.5]])
    for order in ([0, 1], [1, 0]):
        lo = np.full((3, 12), np.nan)
        # the first ray's band (cells 8-9) lies on the free part of the second, longer ray
        insert_rays_inplace(lo, meta, np.array([0.5, 0.5]), ends[order], np.array([True, True]),
                            -0.5, 2.0, -5.0, 5.0, np.array([3.2, 0.0])[order])
        np.testing.assert_allclose(lo[0, :10], -0.5)
        assert lo[0, 10] == 2.0 and lo[0, 11] == 2.0
