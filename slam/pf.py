"""`pf`: Rao-Blackwellized particle filter SLAM with scan-matched proposals (the Gmapping
family: Grisetti, Stachniss, Burgard, "Improved Techniques for Grid Mapping with
Rao-Blackwellized Particle Filters", IEEE T-RO 2007).

Each particle holds a pose, a trajectory (a node in a tree shared by all particles) and
its own count map (copy-on-write tiles, slam/pf_maps.py). Per scan every particle is moved
by the odometry increment with Gmapping's noise (srr, srt, str, stt); once the robot has
travelled linear_update metres or turned angular_update radians since the last update:
  1. scan matching: each particle's pose is refined by hill climbing on its own map, then
     by Hector's Gauss-Newton steps on that map read as a reflectance map, pulled towards
     the motion prior (slam/_kernels/pf_refine.py);
  2. proposal: a Gaussian is fitted to likelihood x motion prior at poses around the
     matched pose; the new pose is drawn from it and the weight multiplied by its
     normaliser eta (the sum of that product);
  3. selective resampling: when Neff < resample_threshold * N, low-variance resampling;
  4. the scan is inserted into every particle's map.
The output map and trajectory are those of the particle with the highest accumulated
weight: its map is re-rendered from the update scans along its trajectory (as Gmapping's
map update does) with occupancy n / visits > occ_thresh; scans between updates get its
pose at the last update moved on by the odometry.
Field comments name the Gmapping (ROS slam_gmapping) parameter each field is.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from worlds.grid import Grid
from slam.base import ImuWindow, OdomDelta, Scan, register
from slam.pose import compose, relative, wrap_angle
from slam.preprocess import PreprocessConfig, preprocess, twist_from_poses
from slam.pf_filter import (effective_sample_size, motion_std, normalized_weights,
                            sample_motion, systematic_resample)
from slam.pf_maps import TiledMaps
from slam.pf_render import render_gmapping, render_surface
from slam._kernels.pf_match import extract_patches, hill_climb, make_params, proposal_moments
from slam._kernels.pf_refine import mean_hit_iterate, mean_hit_patch, reflectance_patch
from slam.gn import match_scan

__all__ = ["MotionConfig", "MatcherConfig", "PfConfig", "ParticleFilterSlam", "refine_pose"]


@dataclass(frozen=True)
class MotionConfig:
    """Odometry noise, standard deviations proportional to the motion (Gmapping's model)."""

    srr: float = 0.1   # srr: translation error (m) per metre translated
    srt: float = 0.2   # srt: rotation error (rad) per metre translated
    str: float = 0.1   # str: translation error (m) per radian rotated
    stt: float = 0.2   # stt: rotation error (rad) per radian rotated
    # floor of the motion prior's standard deviations (m, m, rad) in the proposal, so a
    # particle that barely moved still has a proper prior density
    prior_min_std: tuple[float, float, float] = (0.005, 0.005, 0.005)


@dataclass(frozen=True)
class MatcherConfig:
    """Gmapping's scan matcher and likelihood."""

    sigma: float = 0.05          # sigma: m^2, score of a beam = exp(-d^2 / sigma)
    kernel_size: int = 1         # kernelSize: search window half-width (cells) around each end point
    lstep: float = 0.05          # lstep: initial linear step of the hill climbing (m)
    astep: float = 0.05          # astep: initial angular step (rad)
    iterations: int = 5          # iterations: step halvings of the hill climbing
    lsigma: float = 0.075        # lsigma: m^2, beam log-likelihood = -d^2 / lsigma
    null_likelihood: float = -0.5  # Gmapping's nullLikelihood: unmatched beam = this / lsigma
    # Gmapping's fullnessThreshold (0.1): a cell is occupied for matching above this n / visits.
    # Raised: with range noise of 2.5 % a wall's returns spread over a band of cells and at
    # 0.1 the matcher latches onto the band's front edge, pulling poses off the walls
    fullness: float = 0.3
    ogain: float = 3.0           # ogain: weights smoothed as exp(log w / (ogain * particles))
    lskip: int = 0               # lskip: use every (lskip+1)-th beam for matching
    minimum_score: float = 50.0  # minimumScore (TurtleBot3 value): below it the match is ignored (odometry pose kept)
    # the proposal grid around the matched pose. Gmapping's defaults are 0.01 m and 0.005 rad,
    # steps equal to them; here the hill climb's last step (lstep / 2^iterations, astep /
    # 2^iterations). The likelihood drops by a nullLikelihood whenever a beam stops matching,
    # so it is lumpy at the centimetre scale: on the default grid the fitted mean moved up to
    # the grid's 1 cm half-width from the matched pose at every update, and the error
    # random-walked along corridors (README, pf)
    llsamplerange: float = 0.0015625  # llsamplerange: proposal grid half-width in x and y (m)
    llsamplestep: float = 0.0015625   # llsamplestep: proposal grid step in x and y (m)
    lasamplerange: float = 0.0015625  # lasamplerange: proposal grid half-width in yaw (rad)
    lasamplestep: float = 0.0015625   # lasamplestep: proposal grid step in yaw (rad)
    # Gauss-Newton refinement of the hill climb's pose (not in Gmapping;
    # slam/_kernels/pf_refine.py): Hector's steps on the particle's reflectance map (hits /
    # visits), from which the proposal is then sampled. The hill climb's score is flat within
    # a cell under the LDS-01's range noise and stops centimetres off; the refinement lands on
    # the walls' ridge
    gn_iterations: int = 5        # Gauss-Newton steps per level; 0 = the hill climb alone (stock)
    gn_levels: int = 1            # map levels, coarsest first (level k pools 2^k x 2^k cells)
    gn_max_angle_step: float = 0.2  # rad, clamp of one step's rotation (Hector's)
    # pull towards the motion prior's mean: the cost gains this much per squared prior standard
    # deviation, against Hector's (1 - M)^2 per scan point; along featureless walls it keeps the
    # odometry's motion where the map says nothing
    gn_prior_weight: float = 3.0
    # read the finest level with its ridge at the cells' mean hit points, not at the cell
    # centres (not in Hector; slam/_kernels/pf_refine.py): a wall's face lies where its
    # returns fall in the cell, and read at the centres the rectangle rooms came out 0.2-1 %
    # large once the proposal grid stopped blurring the poses
    gn_mean_hit: bool = True

    def params(self) -> np.ndarray:
        """The kernels' params array (slam/_kernels/pf_match.py)."""
        return make_params(sigma=self.sigma, lsigma=self.lsigma,
                           null_likelihood=self.null_likelihood, fullness=self.fullness,
                           kernel=self.kernel_size, lstep=self.lstep, astep=self.astep,
                           iterations=self.iterations, llsamplerange=self.llsamplerange,
                           llsamplestep=self.llsamplestep, lasamplerange=self.lasamplerange,
                           lasamplestep=self.lasamplestep)


@dataclass(frozen=True)
class PfConfig:
    """Particle-filter SLAM (Gmapping). Defaults: ROS gmapping, update thresholds and ranges
    from the TurtleBot3 gmapping_params.yaml (a 3.5 m lidar in small worlds)."""

    particles: int = 30               # particles
    resample_threshold: float = 0.5   # resampleThreshold: resample when Neff < this * particles
    linear_update: float = 0.2        # linearUpdate (m): filter update after this much travel
    angular_update: float = 0.2       # angularUpdate (rad): ... or after this much rotation
    temporal_update: float = -1.0     # temporalUpdate (s): ... or after this long (< 0: never)
    # maxUrange (m): beams are cropped here (no hit beyond). TurtleBot3 uses 3.0; the whole
    # 3.5 m of the LDS-01 constrains the pose along walls better in the 6 m+ rooms
    max_urange: float = 3.5
    max_range: float = 0.0            # maxRange (m): readings at/after it are no return (0: sensor's)
    delta: float = 0.05               # delta: map resolution (m)
    occ_thresh: float = 0.25          # occ_thresh: output cell occupied when n / visits > this
    map_extent: float = 50.0          # xmin/xmax/ymin/ymax: half side (m) of the square map around the start
    tile: int = 16                    # cells per side of a copy-on-write map tile
    deskew: bool = True               # undo the motion during a revolution (from odometry)
    # each return becomes the mean point of its 2k+1 neighbouring beams before matching and
    # mapping (not in Gmapping; gn's preprocessing): the LDS-01's range noise / 3 on flat walls
    smooth_beams: int = 4
    # output map from every scan (poses between updates from the odometry) or, as Gmapping,
    # from the update scans only
    map_all_scans: bool = False
    # output map: "gmapping" = n / visits > occ_thresh as slam_gmapping publishes; "surface" =
    # that, thinned to the walls' faces (slam/pf_render.py): range noise spreads returns over cells
    render: Literal["gmapping", "surface"] = "surface"
    min_hits: float = 2.0             # surface: a face cell needs at least this many returns
    # smooth_beams of the returns the output map is rendered from (< 0: as matched): averaging
    # over 9 beams rounds a room's corners off the map, over 5 it keeps them
    render_smooth_beams: int = 2
    face_shift: float = 0.2           # surface: cells the faces' returns step into the wall
    motion: MotionConfig = field(default_factory=MotionConfig)
    matcher: MatcherConfig = field(default_factory=MatcherConfig)

    def __post_init__(self):
        if self.particles < 1:
            raise ValueError(f"particles must be >= 1, got {self.particles}")
        if not 0.0 <= self.resample_threshold <= 1.0:
            raise ValueError(f"resample_threshold must lie in [0, 1], got {self.resample_threshold}")
        for name in ("max_urange", "delta", "map_extent"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.tile < 1:
            raise ValueError(f"tile must be >= 1, got {self.tile}")
        if self.smooth_beams < 0:
            raise ValueError(f"smooth_beams must be >= 0, got {self.smooth_beams}")
        m = self.matcher
        if m.gn_iterations < 0 or m.gn_levels < 1 or m.gn_prior_weight < 0:
            raise ValueError("matcher: need gn_iterations >= 0, gn_levels >= 1, "
                             "gn_prior_weight >= 0")


def refine_pose(table: np.ndarray, pool: np.ndarray, grid_meta: np.ndarray, box: np.ndarray,
                points: np.ndarray, pose: np.ndarray, levels: int, iterations: int,
                max_angle_step: float, prior: np.ndarray, prior_w: np.ndarray,
                mean_hit: bool = False) -> np.ndarray:
    """Hector's coarse-to-fine Gauss-Newton (gn's match_scan) on one particle's count map read
    as a reflectance map (slam/_kernels/pf_refine.py).

    table, pool, grid_meta: the particle's tiled map (slam/pf_maps.py); box: (4,) the cells
    read (first row, column, rows, columns); points: (K, 2) scan end points, robot frame, m;
    pose: (3,) start; levels: map levels (level k pools 2^k x 2^k cells); iterations: steps
    per level; prior (3,), prior_w (3,): the quadratic pull towards the motion prior (weights
    per m^2, m^2, rad^2; zeros = none); mean_hit: the finest level is read with its ridge at
    the cells' mean hit points (slam/_kernels/pf_refine.py). Returns the refined (3,) pose.
    """
    res = grid_meta[2]
    corner = (grid_meta[0] + box[1] * res, grid_meta[1] + box[0] * res)
    maps = []
    for level in range(1 if mean_hit else 0, levels):
        prob = reflectance_patch(table, pool, grid_meta, box, 2 ** level)
        maps.append((prob, np.array([*corner, res * 2 ** level, *prob.shape], dtype=np.float64)))
    if not mean_hit:
        return match_scan(maps, points, pose, [iterations] * levels, max_angle_step,
                          check_prior=False, prior=prior, prior_w=prior_w)
    if maps:   # the coarser levels as before, then the finest read at the mean hit points
        pose = match_scan(maps, points, pose, [iterations] * len(maps), max_angle_step,
                          check_prior=False, prior=prior, prior_w=prior_w)
    prob, off_x, off_y, hits = mean_hit_patch(table, pool, grid_meta, box)
    meta = np.array([*corner, res, *prob.shape], dtype=np.float64)
    pts = np.ascontiguousarray(points, dtype=np.float64)
    prior_info = np.diag(np.asarray(prior_w, dtype=np.float64))
    return mean_hit_iterate(prob, off_x, off_y, hits, meta, pts, np.asarray(pose, dtype=np.float64),
                            int(iterations), float(max_angle_step),
                            np.asarray(prior, dtype=np.float64), prior_info)


class _Tree:
    """Trajectory tree shared by all particles: node i has a pose and a parent (-1: root).
    Each filter update adds one node per particle; resampling just copies node ids."""

    def __init__(self):
        self.poses: list[np.ndarray] = []
        self.parents: list[np.ndarray] = []
        self.n = 0

    def add(self, poses: np.ndarray, parents: np.ndarray) -> np.ndarray:
        ids = self.n + np.arange(len(poses))
        self.poses.append(np.array(poses, dtype=np.float64))
        self.parents.append(np.array(parents, dtype=np.int64))
        self.n += len(poses)
        return ids

    def chain(self, node: int) -> np.ndarray:
        """(U, 3) poses from the root to `node`."""
        poses = np.concatenate(self.poses)
        parents = np.concatenate(self.parents)
        out = []
        while node >= 0:
            out.append(poses[node])
            node = parents[node]
        return np.array(out[::-1]).reshape(-1, 3)


@register("pf")
class ParticleFilterSlam:
    """Gmapping-style RBPF; built as ParticleFilterSlam(cfg, start (3,), rng)."""

    config_class = PfConfig
    needs_odometry = True

    def __init__(self, cfg: PfConfig, start: np.ndarray, rng: np.random.Generator):
        self.cfg = cfg
        self.rng = rng
        n = cfg.particles
        self.poses = np.tile(np.asarray(start, dtype=np.float64), (n, 1))
        self.log_w = np.zeros(n)          # weights since the last resampling
        self.weight_sum = np.zeros(n)     # accumulated over the whole run (picks the output)
        self.maps = TiledMaps(n, start[:2], cfg.map_extent, cfg.delta, cfg.tile)
        self.tree = _Tree()
        self.nodes = np.full(n, -1, dtype=np.int64)
        self.params = cfg.matcher.params()
        # no-return beams (inf) are dropped, as Gmapping skips readings beyond maxRange: a
        # dropped reading says nothing about the space along the beam
        self.pre = PreprocessConfig(range_max=cfg.max_range, free_range=0.0, deskew=cfg.deskew,
                                    smooth_beams=cfg.smooth_beams)
        k = cfg.smooth_beams if cfg.render_smooth_beams < 0 else cfg.render_smooth_beams
        self.pre_out = replace(self.pre, smooth_beams=k)
        # per scan: time, odometry pose, index of the filter update it follows
        self._scan_t: list[float] = []
        self._scan_odom: list[np.ndarray] = []
        self._scan_update: list[int] = []
        # per update: odometry pose and the scan (robot frame) inserted
        self._upd_odom: list[np.ndarray] = []
        self._upd_scans: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        # (scan index, origin, ends, hit) of the scans the output map is rendered from
        self._all_scans: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]] = []
        self._last_update_poses = self.poses.copy()
        self._prior_var = np.zeros(3)
        self._linear = self._angular = 0.0
        self._last_update_t = -np.inf
        self.n_resamples = 0
        self.neff_history: list[float] = []

    # --- the filter ---------------------------------------------------------------------
    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None) -> np.ndarray:
        if odom is None:
            raise ValueError("pf needs odometry (run_algorithm checks the log first)")
        first = not self._upd_odom
        if not first:
            delta = odom.delta
            self.poses = self.move(delta)
            self._linear += float(np.hypot(delta[0], delta[1]))
            self._angular += abs(float(delta[2]))
        if first or self.due(scan.t):
            hits, frees, origin, ends, hit = self.beams(scan, odom)
            if not first:
                self.refine_by_proposal(hits, frees, odom.pose)
                self.resample_if_needed()
            self.insert(origin, ends, hit, odom.pose, scan.t)
            rendered = self.output_beams(scan, odom, (origin, ends, hit))
            self._all_scans.append((len(self._scan_t), *rendered))
        elif self.cfg.map_all_scans:
            self._all_scans.append((len(self._scan_t), *self.output_beams(scan, odom)))
        self._scan_t.append(scan.t)
        self._scan_odom.append(np.asarray(odom.pose, dtype=np.float64).copy())
        self._scan_update.append(len(self._upd_odom) - 1)
        return self.poses[self.best()].copy()

    def move(self, delta: np.ndarray) -> np.ndarray:
        """Sample every particle's motion; accumulate the motion prior's variance."""
        m = self.cfg.motion
        self._prior_var += motion_std(delta, m.srr, m.srt, m.str, m.stt) ** 2
        return sample_motion(self.poses, delta, m.srr, m.srt, m.str, m.stt, self.rng)

    def due(self, t: float) -> bool:
        """Gmapping's update rule: enough travel, rotation or (if enabled) time."""
        c = self.cfg
        return (self._linear >= c.linear_update or self._angular >= c.angular_update
                or (c.temporal_update >= 0 and t - self._last_update_t >= c.temporal_update))

    def output_beams(self, scan: Scan, odom: OdomDelta, matched=None):
        """The lidar origin (2,), beam ends (M, 2) and hit flags (M,) the output map is rendered
        from: the returns smoothed over render_smooth_beams (the matcher's 9 beams round the
        corners off). matched: beams(scan, odom)[2:], reused when they are those."""
        if matched is not None and self.pre_out == self.pre:
            return matched
        return self.beams(scan, odom, out=True)[2:]

    def beams(self, scan: Scan, odom: OdomDelta, out: bool = False):
        """Robot-frame beams: matched hit points (K, 2) and their free points one cell closer
        to the lidar, the lidar origin (2,), and all beam ends (M, 2) with hit flags (M,).
        out: preprocessed for the output map (render_smooth_beams) instead."""
        dt = scan.t - self._scan_t[-1] if self._scan_t else 0.0
        twist = twist_from_poses(odom.prev_pose, odom.pose, dt) if dt > 0 else None
        pts = preprocess(scan, self.pre_out if out else self.pre, twist)
        o = pts.origin
        d = pts.points - o
        r = np.linalg.norm(d, axis=1)
        keep = r < self.cfg.max_urange
        # hits beyond maxUrange only clear space up to maxUrange (Gmapping's usableRange)
        far = pts.points[~keep]
        far = o + (far - o) * (self.cfg.max_urange / r[~keep])[:, None]
        hits = pts.points[keep]
        ends = np.vstack([hits, far, pts.misses])
        hit = np.r_[np.ones(len(hits), bool), np.zeros(len(far) + len(pts.misses), bool)]
        step = self.cfg.matcher.lskip + 1
        mh = hits[::step]
        dh = mh - o
        frees = mh - self.cfg.delta * dh / np.maximum(np.linalg.norm(dh, axis=1), 1e-9)[:, None]
        return (np.ascontiguousarray(mh), np.ascontiguousarray(frees),
                np.ascontiguousarray(o, dtype=np.float64), np.ascontiguousarray(ends), hit)

    def refine_by_proposal(self, hits: np.ndarray, frees: np.ndarray, odom_pose: np.ndarray):
        """Scan matching, then the Gaussian proposal around the matched pose; weights *= eta."""
        m, c = self.maps, self.cfg
        # per particle, a dense patch of its map: the reach of the farthest beam end plus
        # room for the matcher's moves, clipped to the tiles the particle has written
        reach = float(np.max(np.linalg.norm(hits, axis=1))) if len(hits) else 0.0
        half = int(np.ceil((reach + 0.5) / c.delta))
        moved = relative(self._upd_odom[-1], odom_pose)
        prior_mean = compose(self._last_update_poses, moved)
        prior_std = np.maximum(np.sqrt(self._prior_var), np.asarray(c.motion.prior_min_std))
        n = len(self.poses)
        # the motion prior as Gauss-Newton weights (per m^2, m^2, rad^2)
        prior_w = c.matcher.gn_prior_weight / prior_std ** 2
        start = np.empty((n, 3))
        mean = np.empty((n, 3))
        cov = np.empty((n, 3, 3))
        log_eta = np.empty(n)
        for p in range(n):
            box = self._patch_box(p, half)
            occ, mean_xy, corner = extract_patches(m.tables[p:p + 1], m.pool, m.grid_meta, box,
                                                   c.matcher.fullness)
            patch = (occ, mean_xy, corner, m.grid_meta)
            pose = self.poses[p:p + 1]
            matched, score = hill_climb(*patch, pose, hits, frees, self.params)
            start[p] = matched[0] if score[0] > c.matcher.minimum_score else pose[0]
            if c.matcher.gn_iterations > 0 and score[0] > c.matcher.minimum_score:
                start[p] = refine_pose(m.tables[p], m.pool, m.grid_meta, box[0], hits, start[p],
                                       c.matcher.gn_levels, c.matcher.gn_iterations,
                                       c.matcher.gn_max_angle_step, prior_mean[p], prior_w,
                                       mean_hit=c.matcher.gn_mean_hit)
            mu, cv, le = proposal_moments(*patch, start[p:p + 1], prior_mean[p:p + 1],
                                          prior_std[None, :], hits, frees, self.params)
            mean[p], cov[p], log_eta[p] = mu[0], cv[0], le[0]
        # a tiny jitter keeps the Cholesky factor defined when the grid likelihood is one-peaked
        chol = np.linalg.cholesky(cov + np.diag([1e-8, 1e-8, 1e-8]))
        z = self.rng.standard_normal((len(start), 3))
        self.poses = mean + np.einsum("nij,nj->ni", chol, z)
        self.poses[:, 2] = wrap_angle(self.poses[:, 2])
        self.log_w += log_eta
        self.weight_sum += log_eta

    def _patch_box(self, p: int, half: int) -> np.ndarray:
        """(1, 4) first row, column, rows, columns of particle p's patch."""
        meta, t = self.maps.grid_meta, self.maps.tile
        r = int(np.floor((self.poses[p, 1] - meta[1]) / meta[2]))
        col = int(np.floor((self.poses[p, 0] - meta[0]) / meta[2]))
        r0, r1, c0, c1 = r - half, r + half, col - half, col + half
        a, b = np.nonzero(self.maps.tables[p] >= 0)
        if len(a):
            r0, r1 = max(r0, a.min() * t), min(r1, (a.max() + 1) * t)
            c0, c1 = max(c0, b.min() * t), min(c1, (b.max() + 1) * t)
        return np.array([[r0, c0, max(r1 - r0, 0), max(c1 - c0, 0)]], dtype=np.int64)

    def resample_if_needed(self) -> None:
        """Low-variance resampling when the effective sample size is below the threshold."""
        w = normalized_weights(self.log_w, self.cfg.matcher.ogain)
        neff = effective_sample_size(w)
        self.neff_history.append(neff)
        if neff < self.cfg.resample_threshold * len(w):
            idx = systematic_resample(w, self.rng)
            self.poses = self.poses[idx]
            self.maps.resample(idx)
            self.nodes = self.nodes[idx]
            self.weight_sum = self.weight_sum[idx]
            self.log_w = np.zeros(len(idx))
            self.n_resamples += 1

    def insert(self, origin: np.ndarray, ends: np.ndarray, hit: np.ndarray, odom_pose: np.ndarray,
               t: float) -> None:
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
        self._upd_scans.append((origin, ends, hit))
        self._last_update_poses = self.poses.copy()
        self._prior_var = np.zeros(3)
        self._linear = self._angular = 0.0
        self._last_update_t = t

    def best(self) -> int:
        """Index of the particle with the highest accumulated weight."""
        return int(np.argmax(self.weight_sum))

    # --- outputs ------------------------------------------------------------------------
    def best_updates(self) -> np.ndarray:
        """(U, 3) the best particle's poses at every filter update."""
        return self.tree.chain(int(self.nodes[self.best()]))

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """Times (N,) and poses (N, 3) at every scan: the best particle's update poses moved on
        by the odometry to the scans in between."""
        upd = self.best_updates()
        if not self._scan_t:
            return np.zeros(0), np.zeros((0, 3))
        u = np.asarray(self._scan_update)
        odom = np.asarray(self._scan_odom)
        upd_odom = np.asarray(self._upd_odom)
        poses = compose(upd[u], relative(upd_odom[u], odom))
        return np.asarray(self._scan_t), poses.reshape(-1, 3)

    def map(self) -> Grid:
        """The best particle's map, re-rendered from the scans along its trajectory (see
        render and map_all_scans): 1.0 occupied, 0.0 free, NaN unknown; cropped."""
        upd = self.best_updates()
        one = TiledMaps(1, self.maps.grid_meta[:2] + self.maps.grid_meta[3] * self.cfg.delta / 2,
                        self.cfg.map_extent, self.cfg.delta, self.cfg.tile)
        _, traj = self.trajectory()
        for i, origin, ends, hit in self._all_scans:
            one.insert(traj[i][None, :], origin, ends, hit)
        counts, r_off, c_off = one.dense_bbox(0)
        hits, visits = counts[..., 0], counts[..., 1]
        if self.cfg.render == "surface":
            rc = np.floor((upd[:, 1::-1] - one.grid_meta[1::-1]) / self.cfg.delta).astype(np.int64)
            # sums of the returns' positions in cell units of this box
            rr, cc = np.indices(hits.shape)
            sum_x = counts[..., 2] / self.cfg.delta + hits * cc
            sum_y = counts[..., 3] / self.cfg.delta + hits * rr
            prob = render_surface(hits, visits, sum_x, sum_y, self.cfg.occ_thresh,
                                  self.cfg.min_hits, rc - np.array([r_off, c_off]),
                                  into=self.cfg.face_shift)
        else:
            prob = render_gmapping(hits, visits, self.cfg.occ_thresh)
        seen = ~np.isnan(prob)
        origin = one.grid_meta[:2] + np.array([c_off, r_off]) * self.cfg.delta
        if seen.any():
            r = np.nonzero(seen.any(axis=1))[0]
            c = np.nonzero(seen.any(axis=0))[0]
            r0, r1 = max(r[0] - 1, 0), min(r[-1] + 2, prob.shape[0])
            c0, c1 = max(c[0] - 1, 0), min(c[-1] + 2, prob.shape[1])
            prob = prob[r0:r1, c0:c1]
            origin = origin + np.array([c0, r0]) * self.cfg.delta
        return Grid(prob, self.cfg.delta, np.array([origin[0], origin[1], 0.0]))

    def finish(self) -> None:
        pass

    def extra_stats(self) -> dict:
        w = normalized_weights(self.log_w, self.cfg.matcher.ogain)
        return {"filter_updates": len(self._upd_odom), "resamplings": self.n_resamples,
                "best_particle": self.best(), "neff_final": effective_sample_size(w),
                "neff_min": float(min(self.neff_history)) if self.neff_history else float(len(w)),
                "map_tiles_in_use": self.maps.tiles_in_use(),
                "map_memory_mb": self.maps.memory_bytes() / 1e6}
