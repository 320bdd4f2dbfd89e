"""graph's local SLAM: what of a scan it matches and inserts."""
import dataclasses

import numpy as np
import pytest

from slam.base import Scan
from slam.graph.config import LocalConfig
from slam.graph.local import LocalSlam
from slam.range_noise import DEFAULT_RANGE_NOISE


@pytest.mark.parametrize("margin", [0.0, 2.0])
def test_the_hits_of_a_wall_at_the_range_limit_are_left_out(margin):
    rng = np.random.default_rng(3)
    angles = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    d = np.where(np.arange(360) < 180, 1.5, 3.45)         # a near wall ahead, a far one behind
    r = d + rng.normal(0.0, 1.0, 360) * DEFAULT_RANGE_NOISE.sigma(d)
    r[r >= 3.5] = np.inf                                    # the lidar loses what lies beyond 3.5 m
    scan = Scan(0.0, r, angles, 0.12, 3.5, np.zeros(3))
    cfg = dataclasses.replace(LocalConfig(), censored_hit_margin=margin, voxel_filter_size=1e-3,
                              randomized_voxel_filter=False)
    _, hits, _, _, _ = LocalSlam(cfg, np.zeros(3)).filter_scan(scan, np.zeros(3))
    far = np.hypot(hits[:, 0], hits[:, 1]) > 2.5
    near_kept = (~far).sum()
    assert near_kept == np.sum((d == 1.5) & np.isfinite(r))
    if margin == 0:
        assert far.sum() == np.sum((d == 3.45) & np.isfinite(r)) > 100
    else:
        assert far.sum() <= 5
