"""`gn`: Gauss-Newton scan-to-map SLAM, the Hector SLAM family (Kohlbrecher, von Stryk,
Meyer, Klingauf: "A flexible and scalable SLAM system with full 3D motion estimation",
SSRR 2011; the hector_mapping ROS package).

Each scan is matched against the map built so far by Gauss-Newton on a smoothly
(bilinearly) interpolated occupancy map, minimising sum_i (1 - M(S_i(xi)))^2 over all scan
end points, from the coarsest map level to the finest. Every level is its own map (reflection
counts by default, or Hector's default log-odds: map_type) updated with the scan, but only
once the robot has moved map_update_distance_thresh or turned map_update_angle_thresh since
the last map update. No wheel odometry; the IMU yaw
rate optionally predicts the rotation between scans and (prior_yaw_weight, not in hector)
pulls every Gauss-Newton step towards that yaw; a direction of translation the scan's surface
normals do not constrain keeps the estimates' constant-velocity prediction (degeneracy_*, not in
hector). Not in hector either: each point reads the map gradient along its own surface normal
(gradient_along_normal), and a weak constant-velocity prior pulls every step
(velocity_prior_weight). The start pose is the log's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from worlds.grid import Grid
from slam.base import ImuWindow, OdomDelta, Scan, register
from slam._kernels.gn_step import NO_NORMALS, gn_iterate
from slam._kernels.normals import normal_information, scan_normals
from slam.mapper import Mapper, MapperConfig, insert_scan_points
from slam.occupancy import LogOddsGrid, ReflectanceGrid, logodds
from slam.pose import relative, transform_points, wrap_angle
from slam.preprocess import PreprocessConfig, preprocess, twist_from_poses, yaw_rate_from_imu

__all__ = ["GnConfig", "MatchPreprocessConfig", "GaussNewtonSlam", "match_scan"]


@dataclass(frozen=True)
class MatchPreprocessConfig(PreprocessConfig):
    """PreprocessConfig with gn's matching defaults (a YAML block keeps those it does not name)."""

    smooth_beams: int = 4      # mean over 9 neighbouring beams: range noise / 3 on flat walls


@dataclass(frozen=True)
class GnConfig:
    """Hector SLAM parameters (hector_mapping names in brackets), defaults for a 5 Hz, 3.5 m lidar."""

    map_resolution: float = 0.05          # [map_resolution] m, cell size of the finest level
    map_multi_res_levels: int = 3         # [map_multi_res_levels] levels; level k has 2^k x the cell size
    # the matching maps' cells (hector: a compile-time choice between GridMapLogOdds, its
    # default, and GridMapReflectanceCount). "reflectance_count": reflections / visits, which
    # keeps the wall's profile under the LDS-01's range noise; "log_odds": hector's default,
    # whose walls saturate several cells thick, so a scan slides within them (update_factor_*,
    # logodds_* and far_* apply to it only)
    map_type: str = "reflectance_count"
    update_factor_free: float = 0.4       # [update_factor_free] occupancy probability of a ray's free cells
    update_factor_occupied: float = 0.9   # [update_factor_occupied] occupancy probability of a hit cell
    map_update_distance_thresh: float = 0.4   # [map_update_distance_thresh] m moved before the map is updated
    map_update_angle_thresh: float = 0.9      # [map_update_angle_thresh] rad turned before the map is updated
    iterations_finest: int = 5            # Gauss-Newton steps at the finest level (hector: 5, hard-coded)
    iterations_coarse: int = 3            # Gauss-Newton steps at every coarser level (hector: 3, hard-coded)
    max_angle_step: float = 0.2           # rad, clamp of one step's rotation (hector: 0.2, hard-coded)
    logodds_min: float = -50.0            # log-odds clamp below (hector: none)
    logodds_max: float = 50.0             # log-odds clamp above (hector: 50, GridMapLogOdds)
    check_prior: bool = True              # also match the finest level from the prior, keep the better (not in hector)
    prior_cost_ratio: float = 1.0         # the coarse-to-fine result must cost less than this x the prior's
    use_imu: bool = True                  # predict the rotation between scans from the gyro (hector: via the imu/tf prior)
    constant_velocity: bool = False       # start the matching at the estimates' mean velocity (hector: at the last pose)
    deskew_velocity_window: float = 1.0   # s; de-skew translation uses the mean velocity of the estimates over this window (0 = rotation only)
    # quadratic pull of every Gauss-Newton step towards the gyro-predicted yaw, in cost per scan
    # point per rad^2 (not in hector, 0 = off): the MPU-9250 gyro's yaw change over one scan
    # is far more precise than the matcher's, whose yaw noise (~0.5 deg) throws walls 3 m
    # away by 2-3 cm; the matcher still corrects the gyro's slow drift
    prior_yaw_weight: float = 30.0
    # value the matcher reads in never-visited cells (hector: 0.5 for both map types). With
    # reflection counts a wall cell reads well below 1 (the range noise spreads the hits), so
    # 0.5 would draw scan points off the walls into unexplored space; 0 = "no reflection seen"
    match_unknown: float = 0.0
    # not in hector: a direction of translation the scan's geometry leaves unconstrained keeps
    # the constant-velocity prediction (degeneracy-aware matching, Zhang, Kaess, Singh, ICRA
    # 2016). Along two parallel walls the count map's texture along the walls, not the walls,
    # decides the motion and holds the estimate still (the corridor). A direction is degenerate
    # when the smaller eigenvalue of the mean outer product of the scan's normals (points off
    # the mapped cells count as none) is below degeneracy_threshold (0 = off; 1/2 for a scan
    # that constrains all directions equally); it is then pulled to the position moved at the
    # estimates' mean velocity over deskew_velocity_window, with degeneracy_weight x points
    # per m^2
    degeneracy_threshold: float = 0.1
    degeneracy_weight: float = 1000.0
    # not in hector: each point reads the map gradient along its surface normal only (the scan
    # normals of the degeneracy check; points without one keep the full gradient), so a point
    # on a wall pulls across the wall, never along it: along a wall the count map's texture
    # (rays at grazing angles cross its face cells without ending there) is not information
    gradient_along_normal: bool = True
    # not in hector: a weak constant-velocity motion model, a pull of every Gauss-Newton step
    # towards the position moved at the estimates' mean velocity (deskew_velocity_window), in
    # cost per scan point per m^2 (0 = off). At 3 and ~300 points it is a prior of sigma
    # ~3 cm per scan: it damps the scan-to-scan jitter of a position that only far, noisy
    # walls pin, and leaves the map in charge wherever it constrains the position
    velocity_prior_weight: float = 3.0
    # scan points for matching ([laser_min_dist, laser_max_dist] are its range limits); smoothing
    # over 9 beams divides the realistic range noise by up to 3 (not in hector)
    preprocess: MatchPreprocessConfig = field(default_factory=MatchPreprocessConfig)
    far_range: float = 0.0                # m; log_odds maps: hits beyond it update with far_factor_occupied (0 = off)
    far_factor_occupied: float = 0.6      # occupancy probability of far hits: far ranges are noisier (not in hector)
    output_map: MapperConfig = field(default_factory=MapperConfig)  # the map the run outputs: every scan at its matched pose

    def __post_init__(self):
        if self.map_resolution <= 0:
            raise ValueError(f"map_resolution must be positive, got {self.map_resolution}")
        if self.map_multi_res_levels < 1:
            raise ValueError(f"map_multi_res_levels must be >= 1, got {self.map_multi_res_levels}")
        if not 0 < self.update_factor_free < 0.5 < self.update_factor_occupied < 1:
            raise ValueError("need 0 < update_factor_free < 0.5 < update_factor_occupied < 1")
        if self.iterations_finest < 1 or self.iterations_coarse < 0:
            raise ValueError("iterations_finest must be >= 1 and iterations_coarse >= 0")
        if self.prior_yaw_weight < 0:
            raise ValueError(f"prior_yaw_weight must be >= 0, got {self.prior_yaw_weight}")
        if not 0.0 <= self.degeneracy_threshold <= 0.5 or self.degeneracy_weight < 0:
            raise ValueError("need 0 <= degeneracy_threshold <= 0.5 and degeneracy_weight >= 0")
        if self.velocity_prior_weight < 0:
            raise ValueError(f"velocity_prior_weight must be >= 0, got {self.velocity_prior_weight}")
        if not 0.0 <= self.match_unknown <= 1.0:
            raise ValueError(f"match_unknown must lie in [0, 1], got {self.match_unknown}")
        if self.map_type not in MAP_TYPES:
            raise ValueError(f"map_type must be one of {', '.join(MAP_TYPES)}, got {self.map_type!r}")
        if self.map_type != "log_odds" and self.far_range > 0:
            raise ValueError("far_range applies to map_type log_odds only (a count has no weaker hit)")

    @property
    def resolutions(self) -> list[float]:
        """Cell size (m) of each level, finest first."""
        return [self.map_resolution * 2 ** k for k in range(self.map_multi_res_levels)]


class _Level:
    """One map level: its grid and the probability image the matcher reads (cached)."""

    def __init__(self, grid: LogOddsGrid | ReflectanceGrid, unknown: float = 0.5):
        self.grid = grid
        self.unknown = float(unknown)
        self._prob = None
        self._meta = None
        self._version = -1

    def prob_meta(self) -> tuple[np.ndarray, np.ndarray]:
        if self._version != self.grid.version:
            # never-touched cells read as match_unknown (hector: log-odds 0, p = 0.5)
            self._prob = np.ascontiguousarray(self.grid.prob(unknown=self.unknown))
            self._meta = self.grid.meta
            self._version = self.grid.version
        return self._prob, self._meta


_NO_PRIOR = np.zeros((3, 3))
# scan normals for the degeneracy check: 2 beams to either side (5 points, about 5 degrees of the
# LDS-01), neighbours at most 0.2 m per beam step away (farther ones are across an edge)
NORMAL_HALF_WINDOW = 2
NORMAL_MAX_GAP = 0.2
MAP_TYPES = ("reflectance_count", "log_odds")


def _matching_grid(cfg: GnConfig, resolution: float, center) -> LogOddsGrid | ReflectanceGrid:
    """One empty matching level of cfg.map_type."""
    if cfg.map_type == "reflectance_count":
        return ReflectanceGrid(resolution, center)
    return LogOddsGrid(resolution, center, logodds(cfg.update_factor_free), logodds(cfg.update_factor_occupied),
                       cfg.logodds_min, cfg.logodds_max)


def _prior_information(prior_w) -> np.ndarray:
    """(3, 3) prior information from None (none), (3,) weights (diagonal) or a (3, 3) matrix."""
    if prior_w is None:
        return _NO_PRIOR
    w = np.asarray(prior_w, dtype=np.float64)
    return np.ascontiguousarray(np.diag(w) if w.ndim == 1 else w)


def _gauss_newton(prob, meta, pts, est, n_it, max_angle_step, prior=None, prior_w=None,
                  normals=NO_NORMALS):
    """n_it Gauss-Newton steps on one level; returns (pose, cost at the returned pose)."""
    est = np.asarray(est, dtype=np.float64)
    prior = est if prior is None else np.asarray(prior, dtype=np.float64)
    return gn_iterate(prob, meta, pts, est, int(n_it), float(max_angle_step), prior,
                      _prior_information(prior_w), normals)


def match_scan(levels: list[tuple[np.ndarray, np.ndarray]], points: np.ndarray, pose: np.ndarray,
               iterations: list[int], max_angle_step: float = 0.2, check_prior: bool = True,
               prior_cost_ratio: float = 1.0, prior: np.ndarray | None = None,
               prior_w: np.ndarray | None = None, normals: np.ndarray | None = None) -> np.ndarray:
    """Hector's coarse-to-fine Gauss-Newton scan matching.

    levels: [(prob (rows, cols), grid_meta (5,))] finest first; points: (N, 2) m in the robot
    frame; pose: (3,) initial world pose; iterations: steps per level, finest first.
    check_prior: also run the finest level from `pose` itself and keep whichever end has the
    lower cost (a coarse level can be biased by up to half its cell, out of the finest
    level's reach); the coarse path wins only with a cost below prior_cost_ratio times the
    prior path's. prior: (3,) motion prior pose; prior_w: its weights, (3,) per coordinate or
    a (3, 3) information matrix (see gn_iterate; None = none). normals: (N, 2) robot-frame
    surface normals, each point's map gradient read along its normal (zero row: the full
    gradient; None = stock Hector). Returns the refined (3,) pose.
    """
    est = np.array(pose, dtype=np.float64)
    pts = np.ascontiguousarray(points, dtype=np.float64)
    nrm = NO_NORMALS if normals is None else np.ascontiguousarray(normals, dtype=np.float64)
    for (prob, meta), n_it in list(zip(levels, iterations))[:0:-1]:
        est, _ = _gauss_newton(prob, meta, pts, est, n_it, max_angle_step, prior, prior_w, nrm)
    prob, meta = levels[0]
    est, cost = _gauss_newton(prob, meta, pts, est, iterations[0], max_angle_step, prior, prior_w, nrm)
    if check_prior and len(levels) > 1:
        alt, alt_cost = _gauss_newton(prob, meta, pts, np.array(pose, dtype=np.float64), iterations[0],
                                      max_angle_step, prior, prior_w, nrm)
        if cost >= prior_cost_ratio * alt_cost:
            est = alt
    return est


@register("gn")
class GaussNewtonSlam:
    """Hector-style SLAM: scan-to-map Gauss-Newton on a multi-resolution occupancy map."""

    config_class = GnConfig

    def __init__(self, cfg: GnConfig, start: np.ndarray, rng: np.random.Generator):
        self.cfg = cfg
        self.levels = [_Level(_matching_grid(cfg, res, start[:2]), cfg.match_unknown) for res in cfg.resolutions]
        self.iterations = [cfg.iterations_finest] + [cfg.iterations_coarse] * (cfg.map_multi_res_levels - 1)
        self.pose = np.asarray(start, dtype=np.float64).copy()
        self._last_update_pose: np.ndarray | None = None
        self._times: list[float] = []
        self._poses: list[np.ndarray] = []
        self._map_updates = 0
        self._degenerate_scans = 0
        self.mapper = Mapper(cfg.output_map, center=start[:2])

    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None) -> np.ndarray:
        predicted, twist, moved_xy = self._predict(scan, imu)
        pts = preprocess(scan, self.cfg.preprocess, twist)
        if self._last_update_pose is None:
            self.pose = predicted  # the first scan builds the map at the start pose
        elif len(pts.points):
            prior_info = np.zeros((3, 3))
            if self.cfg.use_imu and imu is not None and len(imu.gyro):  # no gyro, no yaw prior
                prior_info[2, 2] = self.cfg.prior_yaw_weight * len(pts.points)
            prior = predicted.copy()
            points = np.ascontiguousarray(pts.points, dtype=np.float64)
            # the scan normals feed the gradient projection and the degeneracy check; stock
            # hector (both off) skips them
            normals = (scan_normals(points, NORMAL_HALF_WINDOW, NORMAL_MAX_GAP)
                       if self.cfg.gradient_along_normal or self.cfg.degeneracy_threshold > 0
                       else None)
            if self.cfg.velocity_prior_weight > 0 and len(self._poses) > 1:
                prior[:2] = moved_xy
                prior_info[:2, :2] = self.cfg.velocity_prior_weight * len(points) * np.eye(2)
            degenerate = self._degenerate_direction(points, normals, predicted)
            if degenerate is not None:
                prior[:2] = moved_xy
                # replaces the velocity prior's block: the degenerate direction is held hard,
                # the other one is left to the map
                prior_info[:2, :2] = (self.cfg.degeneracy_weight * len(points)
                                      * np.outer(degenerate, degenerate))
                self._degenerate_scans += 1
            self.pose = match_scan([lv.prob_meta() for lv in self.levels], points, predicted,
                                   self.iterations, self.cfg.max_angle_step, self.cfg.check_prior,
                                   self.cfg.prior_cost_ratio, prior, prior_info,
                                   normals if self.cfg.gradient_along_normal else None)
        else:
            self.pose = predicted
        if self._should_update_map():
            self._insert(pts)
        self.mapper.insert(scan, self.pose, twist)
        self._times.append(scan.t)
        self._poses.append(self.pose.copy())
        return self.pose

    def _degenerate_direction(self, points: np.ndarray, normals: np.ndarray,
                              pose: np.ndarray) -> np.ndarray | None:
        """World-frame unit direction of translation the scan's normals do not constrain (the
        smaller eigenvector of their mean outer product, if its eigenvalue is below
        degeneracy_threshold), else None. points: (N, 2) robot frame; normals: their
        scan_normals (None when the check is off). Points off the coarsest level's observed cells count as points without
        a normal."""
        if self.cfg.degeneracy_threshold <= 0 or not self._poses:
            return None
        # only points on mapped ground constrain the match: a wall coming into view is not in
        # the map until the next map update, and its points read "no reflection" until then
        normals = normals * self.levels[-1].grid.observed(transform_points(pose, points))[:, None]
        lam, vec = np.linalg.eigh(normal_information(normals))
        if lam[0] >= self.cfg.degeneracy_threshold:
            return None
        c, s_ = math.cos(pose[2]), math.sin(pose[2])
        return np.array([c * vec[0, 0] - s_ * vec[1, 0], s_ * vec[0, 0] + c * vec[1, 0]])

    def _predict(self, scan: Scan,
                 imu: ImuWindow | None) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """Pose prior (last pose, optionally moved at the estimates' mean velocity, yaw advanced
        by the gyro), the twist for de-skewing and the position moved at that velocity."""
        pred = self.pose.copy()
        if not self._poses:
            return pred, None, pred[:2].copy()
        dt = scan.t - self._times[-1]
        twist = np.zeros(3)
        win = self.cfg.deskew_velocity_window
        if win > 0 and len(self._poses) > 1:
            # a mean over several scans: the velocity of the last pair alone feeds the matching
            # noise back into the de-skew and makes the estimate oscillate
            k = len(self._times) - 1
            j = k
            while j > 0 and self._times[k] - self._times[j - 1] <= win + 1e-9:
                j -= 1
            if j < k:
                twist = twist_from_poses(self._poses[j], self._poses[k], self._times[k] - self._times[j])
        w = yaw_rate_from_imu(imu) if self.cfg.use_imu else None
        # the body-frame velocity carried along the arc: the chord points at the mid-way yaw
        yaw_mid = pred[2] + 0.5 * (twist[2] if w is None else w) * dt
        c, s_ = math.cos(yaw_mid), math.sin(yaw_mid)
        step = np.array([c * twist[0] - s_ * twist[1], s_ * twist[0] + c * twist[1]]) * dt
        moved_xy = pred[:2] + step
        if self.cfg.constant_velocity:
            pred[:2] = moved_xy
        if w is not None:
            pred[2] = wrap_angle(pred[2] + w * dt)
            twist[2] = w
        return pred, twist, moved_xy

    def _should_update_map(self) -> bool:
        if self._last_update_pose is None:
            return True
        d = relative(self._last_update_pose, self.pose)
        return (math.hypot(d[0], d[1]) > self.cfg.map_update_distance_thresh
                or abs(d[2]) > self.cfg.map_update_angle_thresh)

    def _insert(self, pts) -> None:
        far = self.cfg.far_range
        if far <= 0:
            for lv in self.levels:
                insert_scan_points(lv.grid, pts, self.pose)
        else:
            d = np.hypot(pts.points[:, 0] - pts.origin[0], pts.points[:, 1] - pts.origin[1])
            sensor = transform_points(self.pose, pts.origin[None, :])[0]
            near = transform_points(self.pose, np.vstack([pts.points[d <= far], pts.misses]))
            near_hit = np.r_[np.ones(int((d <= far).sum()), bool), np.zeros(len(pts.misses), bool)]
            far_pts = transform_points(self.pose, pts.points[d > far])
            l_far = logodds(self.cfg.far_factor_occupied)
            for lv in self.levels:
                lv.grid.insert_scan(sensor, far_pts, None, l_occ=l_far)
                lv.grid.insert_scan(sensor, near, near_hit)
        self._last_update_pose = self.pose.copy()
        self._map_updates += 1

    def map(self) -> Grid:
        return self.mapper.to_grid()

    def finish(self) -> None:
        pass

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self._times, dtype=np.float64), np.asarray(self._poses, dtype=np.float64).reshape(-1, 3)

    def extra_stats(self) -> dict:
        return {"map_updates": self._map_updates, "degenerate_scans": self._degenerate_scans}
