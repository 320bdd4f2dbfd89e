"""Tiny, fast algorithms for the bench tests, registered with the real decorator.

fake_map: maps scan end points at the true pose plus seeded noise (needs ground truth, like
the oracle), so repeats differ with the SLAM seed and the metrics have real values.
fake_fixed: fake_map with the same draws whatever the seed, declared deterministic.
fake_raise: raises on its third scan; fake_diverge: its trajectory runs off to 100 m;
fake_interrupt: a Ctrl-C once INTERRUPT["after"] runs are done, else behaves as fake_map.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from slam.base import Slam
from slam.registry import register
from slam.pose import compose, transform_points
from worlds.grid import Grid

INTERRUPT = {"after": None, "built": 0}


@dataclass(frozen=True)
class FakeConfig:
    pose_noise_m: float = 0.01
    delay_s: float = 0.0  # sleep in finish(): a slow run, for the kill-and-resume test


class _Base(Slam):
    config_class = FakeConfig
    uses_ground_truth = True

    def __init__(self, config, start, rng):
        super().__init__(config, start, rng)
        self.cfg = config
        self.t, self.poses, self.points = [], [], []

    def update(self, scan, odom, imu, truth=None):
        pose = np.asarray(truth, float) + self.rng.normal(0, self.cfg.pose_noise_m, 3) * [1, 1, 0.1]
        ok = np.isfinite(scan.ranges)
        r, a = scan.ranges[ok], scan.angles[ok]
        pts = np.stack([r * np.cos(a), r * np.sin(a)], axis=1)
        self.points.append(transform_points(compose(pose, scan.offset), pts))
        self.t.append(scan.t)
        self.poses.append(pose)
        return pose

    def finish(self):
        time.sleep(self.cfg.delay_s)

    def map(self):
        pts = np.vstack(self.points)
        res = 0.05
        lo = np.floor(pts.min(axis=0) / res) * res - res
        idx = np.floor((pts - lo) / res).astype(int)
        shape = (idx[:, 1].max() + 2, idx[:, 0].max() + 2)
        hits = np.zeros(shape)
        np.add.at(hits, (idx[:, 1], idx[:, 0]), 1)
        prob = np.where(hits >= 2, 1.0, np.where(hits > 0, 0.5, np.nan))
        return Grid(prob, res, np.array([lo[0], lo[1], 0.0]))

    def trajectory(self):
        return np.array(self.t), np.array(self.poses)


@register("fake_map")
class FakeMap(_Base):
    pass


@register("fake_fixed")
class FakeFixed(_Base):
    """fake_map without noise: every SLAM seed gives the same run."""

    deterministic = True

    def update(self, scan, odom, imu, truth=None):
        self.rng = np.random.default_rng(0)   # the same draws whatever the seed
        return super().update(scan, odom, imu, truth)


@register("fake_raise")
class FakeRaise(_Base):
    def update(self, scan, odom, imu, truth=None):
        if len(self.t) == 2:
            raise RuntimeError("fake failure on scan 2")
        return super().update(scan, odom, imu, truth)


@register("fake_diverge")
class FakeDiverge(_Base):
    def trajectory(self):
        t, p = super().trajectory()
        p = p.copy()
        p[-1, 0] = 100.0
        return t, p


@register("fake_interrupt")
class FakeInterrupt(_Base):
    """Ctrl-C in the run after the first INTERRUPT["after"] runs of this process."""

    def __init__(self, cfg, start, rng):
        super().__init__(cfg, start, rng)
        INTERRUPT["built"] += 1
        self.stop = INTERRUPT["after"] is not None and INTERRUPT["built"] > INTERRUPT["after"]

    def update(self, scan, odom, imu, truth=None):
        if self.stop:
            raise KeyboardInterrupt
        return super().update(scan, odom, imu, truth)


@register("fake_crash")
class FakeCrash(_Base):
    """Kills its worker process (as a segfault in a compiled kernel would)."""

    def update(self, scan, odom, imu, truth=None):
        import os
        os._exit(3)
