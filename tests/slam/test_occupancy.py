"""LogOddsGrid: growth keeps the lattice and the values, views, copies."""
import numpy as np
import pytest

from slam.occupancy import LogOddsGrid, logodds


def test_logodds_of_hector_factors():
    assert logodds(0.5) == 0.0
    assert logodds(0.9) == pytest.approx(np.log(9.0))
    assert logodds(0.4) == pytest.approx(np.log(0.4 / 0.6))
    with pytest.raises(ValueError):
        logodds(1.0)


def test_grows_to_hold_far_points_and_keeps_old_cells():
    g = LogOddsGrid(0.05, center=(0, 0), size=2.0, block=16)
    g.insert_scan([0.0, 0.0], np.array([[0.5, 0.3]]))
    before = g.to_grid(crop=False)
    occ_xy = before.occupied_xy()
    g.insert_scan([0.0, 0.0], np.array([[7.31, -5.12]]))
    after = g.to_grid(crop=False)
    assert after.rows > before.rows and after.cols > before.cols
    # the origin stays on the lattice and old cells keep their world position
    assert np.allclose(np.round(after.origin[:2] / 0.05), after.origin[:2] / 0.05)
    r, c = after.world_to_cell(occ_xy)
    assert (after.prob[r, c] >= 0.65).all()
    r, c = after.world_to_cell(np.array([[7.31, -5.12]]))
    assert after.prob[r[0], c[0]] == pytest.approx(0.9)
    assert after.shape[0] % 16 == 0 and after.shape[1] % 16 == 0


def test_to_grid_unknown_is_nan_and_crop_keeps_positions():
    g = LogOddsGrid(0.1, center=(3, 3))
    g.insert_scan([3.0, 3.0, 0.0], np.array([[4.0, 3.0], [3.0, 4.5]]), np.array([True, False]))
    full, crop = g.to_grid(crop=False), g.to_grid()
    assert np.isnan(full.prob).sum() > np.isnan(crop.prob).sum()
    assert crop.occupied().sum() == 1
    np.testing.assert_allclose(crop.occupied_xy(), full.occupied_xy())
    assert np.nanmin(crop.prob) == pytest.approx(0.4)
    p = g.prob(unknown=0.5)
    assert not np.isnan(p).any()


def test_copy_is_independent():
    g = LogOddsGrid(0.05)
    g.insert_scan([0, 0], np.array([[1.0, 0.0]]))
    h = g.copy()
    h.insert_scan([0, 0], np.array([[0.0, 1.0]]))
    assert g.to_grid().occupied().sum() == 1
    assert h.to_grid().occupied().sum() == 2


def test_hit_mask_length_checked():
    with pytest.raises(ValueError):
        LogOddsGrid().insert_scan([0, 0], np.zeros((3, 2)), np.ones(2, bool))


def test_reflectance_grid_counts_reflections_over_visits_once_per_scan():
    from slam.occupancy import ReflectanceGrid
    g = ReflectanceGrid(1.0, center=(0, 0), size=16.0, block=16)
    sensor = [0.5, 0.5]
    g.insert_scan(sensor, np.array([[3.5, 0.5]]))                       # hit in cell 3
    g.insert_scan(sensor, np.array([[2.5, 0.5], [2.6, 0.4], [3.2, 0.5]]))  # cell 2 twice, cell 3 through it
    g.insert_scan(sensor, np.array([[4.5, 0.5]]), np.array([False]))    # no return: free to cell 4
    r, c, inside = g.cells(np.array([[x + 0.5, 0.5] for x in range(6)]))
    assert inside.all()
    p = g.prob()[r, c]
    # cell 2: hit once in scan 2 (two rays, one reflection, no extra visit), freed in scans 1 and 3
    # cell 3: hit in scans 1 and 2, freed in scan 3
    np.testing.assert_allclose(p[:5], [0.0, 0.0, 1 / 3, 2 / 3, 0.0])
    assert np.isnan(p[5])                                               # never visited
    assert g.prob(unknown=0.25)[r[5], c[5]] == 0.25


@pytest.mark.parametrize("cls", ["LogOddsGrid", "ReflectanceGrid"])
def test_observed_marks_the_cells_a_scan_touched(cls):
    import slam.occupancy as occ
    grid = (occ.LogOddsGrid(0.1, (0, 0), -0.4, 0.9, -5, 5) if cls == "LogOddsGrid"
            else occ.ReflectanceGrid(0.1, (0, 0)))
    grid.insert_scan(np.array([0.0, 0.0]), np.array([[2.0, 0.0]]))
    seen = grid.observed(np.array([[0.05, 0.0], [1.0, 0.01], [2.0, 0.0], [0.0, 1.0], [500.0, 0.0]]))
    np.testing.assert_array_equal(seen, [True, True, True, False, False])
