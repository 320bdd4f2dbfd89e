"""oracle: maps at the true poses; needs ground truth."""
import numpy as np
import pytest

from sim.logs import SensorLog
from slam.replay import run_algorithm
from worlds.yamlio import InputError

from tests.slam.synthlog import box_room_segments, make_log, score, square_route, truth_grid


@pytest.fixture(scope="module")
def room_log():
    return make_log(box_room_segments(), square_route(), 0.0, seed=2, range_sigma=0.01)


def test_square_room_map_is_the_ceiling(room_log):
    res = run_algorithm("oracle", room_log)
    p, s = score(res.grid, truth_grid(box_room_segments()))
    assert p > 0.95 and s > 0.95, (p, s)
    assert len(res.times) == room_log.n_scans
    np.testing.assert_allclose(res.poses[0], room_log.gt_pose[0])


def test_noisier_ranges_still_give_thin_walls():
    """2.5 % range noise (the realistic profile beyond 0.5 m): the walls stay one cell thick."""
    segs = box_room_segments()
    log = make_log(segs, square_route(), 0.0, seed=3, range_sigma=0.0)
    rng = np.random.default_rng(0)
    noisy = log.scan_ranges * (1 + 0.025 * rng.standard_normal(log.scan_ranges.shape))
    log = SensorLog(**{**log.__dict__, "scan_ranges": noisy})
    grid = run_algorithm("oracle", log).grid
    truth = truth_grid(segs)
    p, s = score(grid, truth)
    # (the synthetic robot's instant turn/drive switches leave a few smeared scans)
    assert p > 0.9 and s > 0.95, (p, s)
    assert grid.occupied().sum() <= 1.1 * truth.occupied().sum()


def test_needs_ground_truth(room_log):
    log = SensorLog(**{**room_log.__dict__, "gt_t": np.zeros(0), "gt_pose": np.zeros((0, 3))})
    with pytest.raises(InputError, match="ground truth"):
        run_algorithm("oracle", log)
