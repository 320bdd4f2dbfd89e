"""graph's local SLAM: what of a scan it matches and inserts."""
import dataclasses

import numpy as np

from slam.base import Scan
from slam.graph.config import LocalConfig
from slam.graph.local import LocalSlam
from slam.range_noise import DEFAULT_RANGE_NOISE


def test_the_hits_of_a_wall_near_the_range_limit_are_kept_and_corrected_for_its_censoring():
    rng = np.random.default_rng(3)
    angles = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    d = np.where(np.arange(360) < 180, 1.5, 3.45)         # a near wall ahead, a far one behind
    r = d + rng.normal(0.0, 1.0, 360) * DEFAULT_RANGE_NOISE.sigma(d)
    r[r >= 3.5] = np.inf                                    # the lidar loses what lies beyond 3.5 m
    scan = Scan(0.0, r, angles, 0.12, 3.5, np.zeros(3))
    cfg = dataclasses.replace(LocalConfig(), voxel_filter_size=1e-3, randomized_voxel_filter=False)
    sp, hits, _, _, _ = LocalSlam(cfg, np.zeros(3)).filter_scan(scan, np.zeros(3))
    dist = np.hypot(hits[:, 0], hits[:, 1])
    far = dist > 2.5
    kept = r[(d == 3.45) & np.isfinite(r)]
    assert far.sum() == len(kept) > 100                     # every hit kept, none made a no-return
    assert len(sp.misses) == np.sum(~np.isfinite(r))
    np.testing.assert_allclose(np.sort(dist[~far]), np.sort(r[(d == 1.5)]), atol=1e-9)
    assert kept.mean() - 3.45 < -0.03                       # the readings that come back are short
    assert abs(dist[far].mean() - 3.45) < 0.01
