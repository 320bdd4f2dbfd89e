"""Resampling an estimate onto the truth's grid: exact at equal geometry, max-pool when finer."""
import numpy as np

from metrics.resample import extended_grid, resample_onto
from worlds.grid import Grid


def test_same_geometry_is_exact(rng):
    p = rng.choice([0.0, 1.0, np.nan, 0.5], size=(20, 30))
    g = Grid(p, 0.05, np.array([1.0, -2.0, 0.0]))
    np.testing.assert_array_equal(resample_onto(g, np.zeros(3), g), p)


def test_finer_estimate_is_max_pooled():
    truth = Grid(np.zeros((10, 10)), 0.1)
    fine = np.zeros((20, 20))
    fine[7, 13] = 1.0  # one fine cell: x in [0.65, 0.70), y in [0.35, 0.40)
    out = resample_onto(Grid(fine, 0.05), np.zeros(3), truth)
    assert out[3, 6] == 1.0 and np.nansum(out >= 0.65) == 1
    assert np.all(out[~np.isnan(out)] >= 0.0)


def test_coarser_estimate_covers_every_fine_cell():
    truth = Grid(np.zeros((20, 20)), 0.05)
    coarse = np.zeros((10, 10))
    coarse[3, 6] = 1.0
    out = resample_onto(Grid(coarse, 0.1), np.zeros(3), truth)
    occ = np.argwhere(out >= 0.65)
    assert sorted(map(tuple, occ)) == [(6, 12), (6, 13), (7, 12), (7, 13)]


def test_transform_moves_cells():
    truth = Grid(np.zeros((10, 10)), 0.1)
    est = np.zeros((10, 10))
    est[2, 2] = 1.0
    out = resample_onto(Grid(est, 0.1), np.array([0.3, 0.1, 0.0]), truth)
    assert np.argwhere(out >= 0.65).tolist() == [[3, 5]]
    # a quarter turn about the world origin: (x, y) -> (-y, x), outside this grid
    ext, (r0, c0) = extended_grid(truth, np.array([[-0.25, 0.25]]))
    out = resample_onto(Grid(est, 0.1), np.array([0.0, 0.0, np.pi / 2]), ext)
    assert np.argwhere(out >= 0.65).tolist() == [[r0 + 2, c0 - 3]]


def test_extended_grid_keeps_truth_in_place():
    truth = Grid(np.ones((4, 5)), 0.1, np.array([0.0, 0.0, 0.0]))
    ext, (r0, c0) = extended_grid(truth, np.array([[-0.55, -0.15], [0.9, 0.2]]))
    np.testing.assert_array_equal(ext.prob[r0:r0 + 4, c0:c0 + 5], truth.prob)
    np.testing.assert_allclose(ext.cell_to_world([r0], [c0]), truth.cell_to_world([0], [0]))
    r, c = ext.world_to_cell(np.array([[-0.55, -0.15], [0.9, 0.2]]))
    assert ext.in_bounds(r, c).all()
