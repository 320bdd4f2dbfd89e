"""Beam-end cells (sim._coverage): the kernel against its numpy reference, and the log's
wall coverage against the same figure computed from the true map and the beam ends."""
import numpy as np
import pytest

from sim._coverage import mark_beam_ends_inplace, mark_beam_ends_ref
from sim.lidar import LidarConfig, beam_poses, cast_scans
from sim.record import _seen_share
from tests.sim.worlds_fixtures import square_room, walled_room
from worlds.coverage import seen_share
from worlds.raster import rasterize


@pytest.mark.kernel
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("yaw", [0.0, 0.3])
def test_kernel_matches_reference(seed, yaw):
    rng = np.random.default_rng(seed)
    origins = rng.uniform(-1, 5, (2000, 2))
    ranges = np.where(rng.random(2000) < 0.1, np.inf, rng.uniform(0, 4, 2000))
    beams = np.flatnonzero(np.isfinite(ranges) & (rng.random(2000) < 0.8))
    angles = rng.uniform(-np.pi, np.pi, len(beams))
    frame = np.array([-0.3, 0.2, 0.05, np.cos(yaw), np.sin(yaw)])
    got = np.zeros((60, 70), dtype=bool)
    want = np.zeros((60, 70), dtype=bool)
    args = (frame, origins, ranges, beams, np.cos(angles), np.sin(angles), 1e-6)
    mark_beam_ends_inplace(got, *args)
    mark_beam_ends_ref(want, *args)
    assert want.any() and not want.all()
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("world", [square_room(), walled_room()])
def test_seen_share_is_the_share_of_wall_cells_holding_a_beam_end(world):
    cfg = LidarConfig()
    rng = np.random.default_rng(3)
    truth = rasterize(world)
    # a few poses in the free space, so that the coverage is partial
    free = truth.free()
    cells = np.argwhere(free)[rng.choice(int(free.sum()), 4, replace=False)]
    xy = truth.cell_to_world(cells[:, 0], cells[:, 1])
    gt = np.c_[xy, rng.uniform(-np.pi, np.pi, len(xy))]
    gt_t = np.arange(len(gt)) * 1.0
    origins, angles = beam_poses(gt_t[:-1], gt_t, gt, cfg)
    ranges = cast_scans(world.segments, origins, angles, np.inf)
    got = _seen_share(world, origins, angles, ranges, cfg)
    ok = np.isfinite(ranges) & (ranges >= cfg.range_min) & (ranges <= cfg.range_max)
    r = ranges[ok][:, None]
    d = np.stack([np.cos(angles[ok]), np.sin(angles[ok])], axis=1)
    ends = np.vstack([origins[ok] + (r - 1e-6) * d, origins[ok] + (r + 1e-6) * d])
    want = seen_share(truth, ends)
    assert 0.0 < want < 1.0
    assert got == want
