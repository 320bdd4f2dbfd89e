"""`pf`: Rao-Blackwellized particle filter SLAM with scan-matched proposals, the Gmapping
family (Grisetti, Stachniss, Burgard, "Improved Techniques for Grid Mapping with
Rao-Blackwellized Particle Filters", IEEE T-RO 2007). The method step by step, with what
differs from GMapping: docs/algorithms/pf.md.
"""
from __future__ import annotations

import numpy as np

from worlds.grid import Grid
from slam.base import ImuWindow, OdomDelta, Scan, Slam
from slam.output_map import output_map_from_trajectory
from slam.pf.config import PfConfig
from slam.pf.defaults import derive_pf_config
from slam.pf.maps import TiledMaps
from slam.pf.motion import (effective_sample_size, motion_std, normalized_weights,
                            sample_motion, systematic_resample)
from slam.pf.odometry import ImuHeadingOdometry
from slam.pf.proposal import propose
from slam.pf.tree import TrajectoryTree
from slam.pose import compose, relative
from slam.preprocess import PreprocessConfig, preprocess, sweep_twist, twist_from_poses

__all__ = ["ParticleFilterSlam"]


class ParticleFilterSlam(Slam):
    """Gmapping-style RBPF: particles with their own maps and a shared trajectory tree."""

    config_class = PfConfig
    needs_odometry = True
    family = "Gmapping"
    compile_cost_s = 21.0   # s, cold, its own kernels (docs/benchmark.md#cost)

    @classmethod
    def derive_config(cls, sensors) -> list:
        """The values this algorithm takes from the log's sensors (slam/pf/defaults.py)."""
        return derive_pf_config(sensors)

    def __init__(self, config: PfConfig, start: np.ndarray, rng: np.random.Generator):
        super().__init__(config, start, rng)
        n = config.particles
        self.poses = np.tile(np.asarray(start, dtype=np.float64), (n, 1))
        self.log_w = np.zeros(n)          # weights since the last resampling
        self.weight_sum = np.zeros(n)     # accumulated over the whole run (picks the output)
        self.maps = TiledMaps(n, start[:2], config.map_extent, config.delta, config.tile)
        self.tree = TrajectoryTree()
        self.nodes = np.full(n, -1, dtype=np.int64)
        self.params = config.matcher.params()
        # no-return beams (inf) are dropped, as Gmapping skips readings beyond maxRange: a
        # dropped reading says nothing about the space along the beam
        self.pre = PreprocessConfig(range_max=config.max_range, free_range=0.0,
                                    smooth_beams=config.smooth_beams)
        self._scans: list[Scan] = []
        self._scan_odom: list[np.ndarray] = []
        self._scan_update: list[int] = []     # per scan: the filter update it follows
        self._upd_odom: list[np.ndarray] = []  # per filter update: the odometry pose
        self._last_update_poses = self.poses.copy()
        self._prior_var = np.zeros(3)
        self._linear = self._angular = 0.0
        self._n_seen = 0                      # scans handed to update
        self._odometry = ImuHeadingOdometry() if config.odometry_heading == "imu" else None
        self._sampled_odom: np.ndarray | None = None   # odometry where motion was last sampled
        self.n_resamples = 0
        self.neff_history: list[float] = []

    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None) -> np.ndarray:
        """On every throttle_scans-th scan: 1. move every particle by the odometry since the last
        such scan, with sampled noise; once the robot travelled linear_update or turned
        angular_update: 2. scan matching and the proposal per particle (weights x eta);
        3. selective resampling; 4. the scan into every particle's map. Other scans only take
        their place on the trajectory (by odometry from the last filter update)."""
        if self._odometry is not None:
            odom = self._odometry.update(scan.t, odom, imu)
        first = not self._upd_odom
        self._n_seen += 1
        if not first and (self._n_seen - 1) % self.config.throttle_scans:
            self._record(scan, odom)
            return compose(self.poses[self.best()], relative(self._sampled_odom, odom.pose))
        if not first:
            self._move(relative(self._sampled_odom, odom.pose))
        self._sampled_odom = np.asarray(odom.pose, dtype=np.float64).copy()
        if first or self._update_due():
            hits, frees, origin, ends, hit = self._beams(scan, odom)
            if not first:
                self._propose(hits, frees, odom.pose)
                self._resample_if_needed()
            self._insert(origin, ends, hit, odom.pose)
        self._record(scan, odom)
        return self.poses[self.best()].copy()

    def _record(self, scan: Scan, odom: OdomDelta) -> None:
        self._scans.append(scan)
        self._scan_odom.append(np.asarray(odom.pose, dtype=np.float64).copy())
        self._scan_update.append(len(self._upd_odom) - 1)

    def _move(self, delta: np.ndarray) -> None:
        """Sample every particle's motion; accumulate the motion prior's variance and the travel."""
        m = self.config.motion
        self._prior_var += motion_std(delta, m.srr, m.srt, m.str, m.stt) ** 2
        self.poses = sample_motion(self.poses, delta, m.srr, m.srt, m.str, m.stt, self.rng)
        self._linear += float(np.hypot(delta[0], delta[1]))
        self._angular += abs(float(delta[2]))

    def _update_due(self) -> bool:
        """Gmapping's update rule: enough travel or rotation since the last update."""
        return self._linear >= self.config.linear_update or self._angular >= self.config.angular_update

    def _beams(self, scan: Scan, odom: OdomDelta):
        """Robot-frame beams: matched hit points (K, 2) and their free points one cell closer
        to the lidar, the lidar origin (2,), and all beam ends (M, 2) with hit flags (M,)."""
        c = self.config
        dt = scan.t - self._scans[-1].t if self._scans else 0.0
        # de-skew with the odometry of the scan's revolution
        before = twist_from_poses(odom.prev_pose, odom.pose, dt) if dt > 0 else None
        twist = sweep_twist(scan, odom, None, before)
        pts = preprocess(scan, self.pre, twist)
        o = pts.origin
        r = np.linalg.norm(pts.points - o, axis=1)
        keep = r < c.max_urange
        # hits beyond maxUrange only clear space up to maxUrange (Gmapping's usableRange)
        far = o + (pts.points[~keep] - o) * (c.max_urange / r[~keep])[:, None]
        hits = pts.points[keep]
        ends = np.vstack([hits, far, pts.misses])
        hit = np.r_[np.ones(len(hits), bool), np.zeros(len(far) + len(pts.misses), bool)]
        mh = hits[::c.matcher.lskip + 1]
        dh = mh - o
        frees = mh - c.delta * dh / np.maximum(np.linalg.norm(dh, axis=1), 1e-9)[:, None]
        return (np.ascontiguousarray(mh), np.ascontiguousarray(frees),
                np.ascontiguousarray(o, dtype=np.float64), np.ascontiguousarray(ends), hit)

    def _propose(self, hits: np.ndarray, frees: np.ndarray, odom_pose: np.ndarray) -> None:
        """Every particle's new pose from the improved proposal; weights *= eta."""
        moved = relative(self._upd_odom[-1], odom_pose)
        prior_mean = compose(self._last_update_poses, moved)
        prior_std = np.maximum(np.sqrt(self._prior_var), np.asarray(self.config.motion.prior_min_std))
        self.poses, log_eta = propose(self.config, self.maps, self.poses, prior_mean, prior_std,
                                      hits, frees, self.params, self.rng)
        self.log_w += log_eta
        self.weight_sum += log_eta

    def _resample_if_needed(self) -> None:
        """Low-variance resampling when the effective sample size is below the threshold."""
        w = normalized_weights(self.log_w, self.config.matcher.ogain)
        neff = effective_sample_size(w)
        self.neff_history.append(neff)
        if neff < self.config.resample_threshold * len(w):
            idx = systematic_resample(w, self.rng)
            self.poses = self.poses[idx]
            self.maps.resample(idx)
            self.nodes = self.nodes[idx]
            self.weight_sum = self.weight_sum[idx]
            self.log_w = np.zeros(len(idx))
            self.n_resamples += 1

    def _insert(self, origin: np.ndarray, ends: np.ndarray, hit: np.ndarray,
                odom_pose: np.ndarray) -> None:
        """Register the scan in every particle's map; extend the trajectories."""
        if not self._upd_odom:
            # all particles start identical: insert once and share the tiles
            self.maps.resample(np.zeros(1, dtype=np.int64))
            self.maps.insert(self.poses[:1], origin, ends, hit)
            self.maps.resample(np.zeros(len(self.poses), dtype=np.int64))
        else:
            self.maps.insert(self.poses, origin, ends, hit)
        self.nodes = self.tree.add(self.poses, self.nodes)
        self._upd_odom.append(np.asarray(odom_pose, dtype=np.float64).copy())
        self._last_update_poses = self.poses.copy()
        self._prior_var = np.zeros(3)
        self._linear = self._angular = 0.0

    def best(self) -> int:
        """Index of the particle with the highest accumulated weight."""
        return int(np.argmax(self.weight_sum))

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """Times (N,) and poses (N, 3) at every scan: the best particle's update poses moved on
        by the odometry to the scans in between."""
        if not self._scans:
            return np.zeros(0), np.zeros((0, 3))
        upd = self.tree.chain(int(self.nodes[self.best()]))
        u = np.asarray(self._scan_update)
        poses = compose(upd[u], relative(np.asarray(self._upd_odom)[u], np.asarray(self._scan_odom)))
        return np.array([s.t for s in self._scans]), poses.reshape(-1, 3)

    def map(self) -> Grid:
        """The output map of every scan along the best particle's trajectory."""
        times, poses = self.trajectory()
        return output_map_from_trajectory(self.config.output_map, self._scans, times, poses)

    def extra_stats(self) -> dict:
        w = normalized_weights(self.log_w, self.config.matcher.ogain)
        return {"filter_updates": len(self._upd_odom), "resamplings": self.n_resamples,
                "best_particle": self.best(), "neff_final": effective_sample_size(w),
                "neff_min": float(min(self.neff_history)) if self.neff_history else float(len(w)),
                "map_tiles_in_use": self.maps.tiles_in_use(),
                "map_memory_mb": self.maps.memory_bytes() / 1e6}
