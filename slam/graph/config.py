"""GraphConfig: the options of the pose-graph SLAM, shaped like Cartographer's Lua options.

Each field names the Cartographer option it stands for (TRAJECTORY_BUILDER_2D.* for the local
SLAM, POSE_GRAPH.* for the global SLAM). Values are Cartographer's 2D defaults
(trajectory_builder_2d.lua, pose_graph.lua) except where the TurtleBot3 configuration
(turtlebot3_cartographer/config/turtlebot3_lds_2d.lua) overrides them for its LDS-01 lidar:
min_range 0.12, max_range 3.5, missing_data_ray_length 3.0, use_imu_data true,
use_online_correlative_scan_matching true, constraint_builder.min_score 0.65. Deviations of
ours are marked "ours".
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from slam.output_map import OutputMapConfig

__all__ = ["GraphConfig", "LocalConfig", "GlobalConfig", "MotionFilterConfig", "SubmapsConfig", "TsdfInserterConfig",
           "RealTimeCorrelativeConfig", "CeresScanMatcherConfig", "FastCorrelativeConfig",
           "ConstraintBuilderConfig", "OptimizationConfig", "AdaptiveVoxelConfig"]


def _positive(obj, *names):
    for n in names:
        if not getattr(obj, n) > 0:
            raise ValueError(f"{n} must be positive, got {getattr(obj, n)}")


@dataclass(frozen=True)
class MotionFilterConfig:
    """TRAJECTORY_BUILDER_2D.motion_filter: a scan becomes a node only after this much motion."""

    max_time_seconds: float = 5.0             # s since the last node
    max_distance_meters: float = 0.2          # m from the last node
    max_angle_radians: float = math.radians(0.1)   # TB3 (Cartographer 1 deg): most scans become nodes


@dataclass(frozen=True)
class AdaptiveVoxelConfig:
    """TRAJECTORY_BUILDER_2D.adaptive_voxel_filter (and loop_closure_adaptive_voxel_filter)."""

    max_length: float = 0.5          # m, the voxel size the filter starts from (its largest)
    min_num_points: int = 200        # smallest voxel that keeps at least this many points
    max_range: float = 50.0          # m, points farther are dropped


@dataclass(frozen=True)
class RealTimeCorrelativeConfig:
    """TRAJECTORY_BUILDER_2D.real_time_correlative_scan_matcher (Olson's exhaustive search)."""

    linear_search_window: float = 0.1                   # m either side of the prediction
    angular_search_window: float = math.radians(20.0)   # rad either side
    translation_delta_cost_weight: float = 1e-1         # penalty per m from the prediction
    rotation_delta_cost_weight: float = 1e-1            # penalty per rad from the prediction
    # ours: the rotation penalty rises to gain / sigma (0 = off), sigma the spread of the last
    # scans' yaw innovations (the yaw the scan alone prefers, less the prediction's) or the
    # angular step if larger: odometry the scans confirm then guides the yaw; raw keeps the weight
    rotation_delta_cost_gain: float = 0.005

    def __post_init__(self):
        if self.rotation_delta_cost_gain < 0:
            raise ValueError(f"rotation_delta_cost_gain must be >= 0, got {self.rotation_delta_cost_gain}")


@dataclass(frozen=True)
class CeresScanMatcherConfig:
    """TRAJECTORY_BUILDER_2D.ceres_scan_matcher: least squares on the interpolated grid."""

    occupied_space_weight: float = 1.0       # weight of the grid term (1 - M) per point (local SLAM: 6)
    translation_weight: float = 10.0         # pull to the prediction per m (local SLAM: 300)
    rotation_weight: float = 40.0            # pull to the prediction per rad (local SLAM: 330)
    max_num_iterations: int = 20     # ceres_solver_options.max_num_iterations


@dataclass(frozen=True)
class TsdfInserterConfig:
    """TRAJECTORY_BUILDER_2D.submaps.range_data_inserter.tsdf_range_data_inserter (TSDF submaps;
    slam/graph/tsdf.py). Not implemented: update_free_space (false, as Cartographer's default)
    and update_weight_range_exponent (0, its default)."""

    # ours 0.1 (Cartographer 0.3): the residual is tsd / truncation, so the band's slope sets
    # how hard a scan pulls against the odometry prior
    truncation_distance: float = 0.1         # m: cells this far before and behind a hit, along its ray
    maximum_weight: float = 10.0             # a cell's summed weight is capped here, so old views fade
    # ours 10 (Cartographer 4): with the LDS-01's range noise, normals from two neighbours a
    # side tilt by degrees near the robot
    num_normal_samples: int = 10             # normal_estimation_options.num_normal_samples
    sample_radius: float = 0.5               # normal_estimation_options.sample_radius, m: farther
                                             # neighbours end the sample window
    # Gaussian kernels on an update's weight: of the angle between normal and ray, and of the
    # signed distance of the cell from the hit
    update_weight_angle_scan_normal_to_ray_kernel_bandwidth: float = 0.5   # rad; 0 = off
    update_weight_distance_cell_to_hit_kernel_bandwidth: float = 0.5       # m; 0 = off
    # ours: a directional TSDF (Splietker and Behnke 2019) beside the one field: this many more
    # fields, one per normal direction, and the least squares reads each point's from its normal,
    # so the two faces of a thin wall do not average into each other (0 = the one field,
    # Cartographer's)
    normal_directions: int = 4

    def __post_init__(self):
        _positive(self, "truncation_distance", "maximum_weight", "num_normal_samples", "sample_radius")
        if self.normal_directions != 0 and self.normal_directions < 3:
            raise ValueError(f"normal_directions must be 0 or >= 3, got {self.normal_directions}")
        for n in ("update_weight_angle_scan_normal_to_ray_kernel_bandwidth",
                  "update_weight_distance_cell_to_hit_kernel_bandwidth"):
            if getattr(self, n) < 0:
                raise ValueError(f"{n} must be >= 0, got {getattr(self, n)}")


@dataclass(frozen=True)
class SubmapsConfig:
    """TRAJECTORY_BUILDER_2D.submaps: TSDF or probability-grid submaps, two active at a time."""

    num_range_data: int = 90                 # scans a submap takes before the next one starts
    resolution: float = 0.05                 # grid_options_2d.resolution, m
    # grid_options_2d.grid_type: "tsdf" (ours as default; Cartographer's TSDF option) or
    # "probability_grid" (Cartographer's default, which puts a wall at the centres of its hit
    # cells, up to half a cell off, and its matches carry that bias)
    grid_type: str = "tsdf"
    tsdf: TsdfInserterConfig = field(default_factory=TsdfInserterConfig)
    # probability_grid only:
    hit_probability: float = 0.55            # probability_grid: odds of a hit cell (probability_grid_inserter_options_2d)
    miss_probability: float = 0.49           # probability_grid: odds of a freed cell
    min_probability: float = 0.1             # probability_grid: clamp below (Cartographer's kMinProbability)
    max_probability: float = 0.9             # probability_grid: clamp above
    # ours: a hit ray frees space only up to this many range sigmas short of the hit (0 = up to
    # the hit cell, as Cartographer); the band is marked observed, not free, so short beams do
    # not erode a wall's front
    free_space_margin_sigmas: float = 1.5
    # the lidar's range noise, 1 sigma = max(range_sigma_min, range_sigma_ratio * range): the
    # LDS-01 datasheet's +-15 mm below 0.5 m and +-5 % beyond, read as 2-sigma bounds
    range_sigma_min: float = 0.0075          # m, the noise below 0.3 m
    range_sigma_ratio: float = 0.025         # of the range, the noise beyond

    def __post_init__(self):
        _positive(self, "num_range_data", "resolution")
        if self.grid_type not in ("tsdf", "probability_grid"):
            raise ValueError(f"grid_type must be 'tsdf' or 'probability_grid', got {self.grid_type!r}")
        for n in ("free_space_margin_sigmas", "range_sigma_min", "range_sigma_ratio"):
            if getattr(self, n) < 0:
                raise ValueError(f"{n} must be >= 0, got {getattr(self, n)}")
        for n in ("hit_probability", "miss_probability", "min_probability", "max_probability"):
            if not 0.0 < getattr(self, n) < 1.0:
                raise ValueError(f"{n} must lie in (0, 1), got {getattr(self, n)}")


@dataclass(frozen=True)
class LocalConfig:
    """TRAJECTORY_BUILDER_2D: scan-to-submap matching (local SLAM)."""

    min_range: float = 0.12                  # m, closer readings are dropped (TB3)
    max_range: float = 3.5                   # m, farther readings are no return (TB3)
    missing_data_ray_length: float = 3.0     # TB3; no-return beams free space up to this range
    voxel_filter_size: float = 0.025         # m, one point per voxel before insertion
    # Cartographer's voxel filters keep a random point of each voxel (RandomizedVoxelFilter);
    # false keeps the first, which favours the first beams of the sweep
    randomized_voxel_filter: bool = True
    use_imu_data: bool = True                # TB3: yaw rate from the gyro in the extrapolator
    # ours: s, time constant of the gyro bias the extrapolator learns from the scan matcher's
    # rotation corrections (0: none; Cartographer trusts the gyro's rate as it comes). A
    # calibrated MEMS gyro keeps ~0.01 deg/s of bias, which the pull to the prediction passes
    # into the submaps
    gyro_bias_time_constant: float = 30.0
    use_online_correlative_scan_matching: bool = False  # Cartographer default (TB3: true; its
                                             # 1-cell / 0.8 deg lattice then anchors the rotation)
    match_near_range: float = 2.6            # ours: > 0 weights each point in the least squares by
                                             # min(1, (match_near_range / range)^2); 0 = uniform
    motion_filter: MotionFilterConfig = field(default_factory=MotionFilterConfig)
    adaptive_voxel_filter: AdaptiveVoxelConfig = field(default_factory=AdaptiveVoxelConfig)
    real_time_correlative_scan_matcher: RealTimeCorrelativeConfig = field(
        default_factory=RealTimeCorrelativeConfig)
    # ours: the pulls to the prediction 50 and 55 times the grid term's weight, not 10 and 40
    # times: along a corridor the grid pins nothing and the odometry's prediction is the better
    # guide. These weights, match_near_range and the pose graph's matcher weights were chosen by
    # `bench tune` on generated offices and warehouses and held on unseen seeds
    ceres_scan_matcher: CeresScanMatcherConfig = field(
        default_factory=lambda: CeresScanMatcherConfig(
            occupied_space_weight=6.0, translation_weight=300.0, rotation_weight=330.0))
    submaps: SubmapsConfig = field(default_factory=SubmapsConfig)

    def __post_init__(self):
        _positive(self, "max_range", "voxel_filter_size")
        if self.gyro_bias_time_constant < 0:
            raise ValueError(f"gyro_bias_time_constant must be >= 0, got {self.gyro_bias_time_constant}")


@dataclass(frozen=True)
class FastCorrelativeConfig:
    """POSE_GRAPH.constraint_builder.fast_correlative_scan_matcher (branch and bound)."""

    linear_search_window: float = 1.0        # ours (Cartographer 7 m): room-sized worlds, where 7 m
                                             # reaches the other sides of a ring corridor
    angular_search_window: float = math.radians(30.0)
    branch_and_bound_depth: int = 7          # precomputation grids: the coarsest covers 2^6 cells


@dataclass(frozen=True)
class ConstraintBuilderConfig:
    """POSE_GRAPH.constraint_builder: loop-closure search between nodes and finished submaps."""

    sampling_ratio: float = 0.3              # share of (node, submap) pairs searched
    max_constraint_distance: float = 15.0    # m; farther pairs are not searched
    min_score: float = 0.6                   # ours (TB3 0.65, Cartographer 0.55): closures just
                                             # under TB3's threshold hold cluttered routes' drift
    loop_closure_translation_weight: float = 1.1e4   # weight of a loop closure per m
    loop_closure_rotation_weight: float = 1e5        # ... per rad
    min_information_ratio: float = 0.1       # ours: a match this degenerate constrains only across
                                             # its weak direction (0 = off)
    ambiguity_radius: float = 0.3            # ours: reject a match when a pose this far (m) from it,
                                             # unless along its weak direction (min_information_ratio)
    ambiguity_margin: float = 0.02           # scores within this margin of the best (0 radius = off)
    # ours: reject a match when more than this fraction of its points have space the submap knows
    # to be free (probability below see_through_free_probability) one submap cell beyond them
    # along the beam: the scan would see through a surface. This is the far face of a thin wall,
    # mapped from its other side, that a hit-only score cannot tell from the near face (0 = off)
    max_see_through_ratio: float = 0.05
    see_through_free_probability: float = 0.3   # a cell below this probability is known free
    fast_correlative_scan_matcher: FastCorrelativeConfig = field(default_factory=FastCorrelativeConfig)
    ceres_scan_matcher: CeresScanMatcherConfig = field(default_factory=lambda: CeresScanMatcherConfig(
        occupied_space_weight=20.0, translation_weight=10.0, rotation_weight=1.0, max_num_iterations=10))
    # ours 0.3 m and 300 points (Cartographer 0.9 and 100): with the closures' points on cells
    # the submap never saw left out of the refinement, denser clouds make closer closures
    loop_closure_adaptive_voxel_filter: AdaptiveVoxelConfig = field(
        default_factory=lambda: AdaptiveVoxelConfig(max_length=0.3, min_num_points=300))

    def __post_init__(self):
        if not 0.0 <= self.max_see_through_ratio <= 1.0:
            raise ValueError(f"max_see_through_ratio must lie in [0, 1], got {self.max_see_through_ratio}")
        if not 0.0 < self.see_through_free_probability < 1.0:
            raise ValueError(f"see_through_free_probability must lie in (0, 1), "
                             f"got {self.see_through_free_probability}")


@dataclass(frozen=True)
class OptimizationConfig:
    """POSE_GRAPH.optimization_problem: sparse pose adjustment. Cartographer's odometry
    constraints are not built: the wheel odometry only predicts (see LocalConfig)."""

    huber_scale: float = 1.0                 # ours (Cartographer 10): TSDF submaps' closures are precise
    local_slam_pose_translation_weight: float = 1e5   # consecutive nodes' local-SLAM motion, per m
    local_slam_pose_rotation_weight: float = 1e5      # ... per rad
    max_num_iterations: int = 50             # ceres_solver_options.max_num_iterations
    max_loop_residual: float = 0.25          # ours: loop closures off by more (m) after optimizing
                                             # are dropped and the problem solved again (0 = keep all)


@dataclass(frozen=True)
class GlobalConfig:
    """POSE_GRAPH: loop closure and optimization."""

    enable_loop_closure: bool = True         # ours: false = no constraint search (local SLAM + SPA)
    optimize_every_n_nodes: int = 90         # nodes between optimizations (0 = only at the end)
    matcher_translation_weight: float = 190.0  # intra-submap (local) constraints, per m (Cartographer 5e2)
    matcher_rotation_weight: float = 1.43e3    # ... per rad (Cartographer 1.6e3)
    constraint_builder: ConstraintBuilderConfig = field(default_factory=ConstraintBuilderConfig)
    optimization_problem: OptimizationConfig = field(default_factory=OptimizationConfig)


@dataclass(frozen=True)
class GraphConfig:
    """The pose-graph SLAM: local SLAM (trajectory_builder) + global SLAM (pose_graph)."""

    trajectory_builder: LocalConfig = field(default_factory=LocalConfig)
    pose_graph: GlobalConfig = field(default_factory=GlobalConfig)
    # ours, offline (slam/configs/graph_gyro_calibrated.yaml): run the log twice; the gyro's
    # mean bias, read from the first run's optimized yaw (slam/graph/calibration.py), is taken
    # out of the gyro for the second. Twice the run time
    calibrate_gyro: bool = False
    calibrated_rotation_weight: float = 1000.0   # ours: the second run's local pull to the calibrated
                                                 # gyro's prediction, per rad (in place of the
                                                 # local matcher's rotation_weight, 330)
    output_map: OutputMapConfig = field(default_factory=OutputMapConfig)

    def __post_init__(self):
        if not self.calibrated_rotation_weight >= 0:
            raise ValueError(f"calibrated_rotation_weight must be >= 0, got {self.calibrated_rotation_weight}")
