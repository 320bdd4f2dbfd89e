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

from slam.mapper import MapperConfig

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

    max_time_seconds: float = 5.0
    max_distance_meters: float = 0.2
    max_angle_radians: float = math.radians(0.1)   # TB3 (Cartographer 1 deg): nearly every scan
                                                   # becomes a node; measured far better maps here


@dataclass(frozen=True)
class AdaptiveVoxelConfig:
    """TRAJECTORY_BUILDER_2D.adaptive_voxel_filter (and loop_closure_adaptive_voxel_filter)."""

    max_length: float = 0.5          # m, largest voxel tried
    min_num_points: int = 200        # smallest voxel that keeps at least this many points
    max_range: float = 50.0          # m, points farther are dropped


@dataclass(frozen=True)
class RealTimeCorrelativeConfig:
    """TRAJECTORY_BUILDER_2D.real_time_correlative_scan_matcher (Olson's exhaustive search)."""

    linear_search_window: float = 0.1
    angular_search_window: float = math.radians(20.0)
    translation_delta_cost_weight: float = 1e-1
    rotation_delta_cost_weight: float = 1e-1


@dataclass(frozen=True)
class CeresScanMatcherConfig:
    """TRAJECTORY_BUILDER_2D.ceres_scan_matcher: least squares on the interpolated grid."""

    occupied_space_weight: float = 1.0
    translation_weight: float = 10.0         # the local SLAM's default is raised to 100 (see LocalConfig)
    rotation_weight: float = 40.0
    max_num_iterations: int = 20     # ceres_solver_options.max_num_iterations


@dataclass(frozen=True)
class TsdfInserterConfig:
    """TRAJECTORY_BUILDER_2D.submaps.range_data_inserter.tsdf_range_data_inserter (TSDF submaps;
    slam/graph/tsdf.py). Not implemented: update_free_space (false, as Cartographer's default)
    and update_weight_range_exponent (0, its default)."""

    # ours 0.1 (Cartographer 0.3): the matcher's residual is tsd / truncation, so the band's
    # slope sets how hard the scan pulls against the odometry prior; with 0.3 m the loop world
    # (lanes 0.55 m from the walls) drifted 2.4 cm on average (P 0.68), with 0.1 m 1.2 cm (0.95)
    truncation_distance: float = 0.1         # m: cells this far before and behind a hit, along its ray
    maximum_weight: float = 10.0             # a cell's summed weight is capped here, so old views fade
    # ours 10 (Cartographer 4): with the LDS-01's range noise, normals from two neighbours a
    # side tilt by degrees near the robot, and the projected distances with them: without loop
    # closure the loop world's heading error was +0.87 deg on average (P 0.55); five a side
    # hold it to +0.05 deg (P 0.92)
    num_normal_samples: int = 10             # normal_estimation_options.num_normal_samples
    sample_radius: float = 0.5               # normal_estimation_options.sample_radius, m: farther
                                             # neighbours end the sample window
    project_sdf_distance_to_scan_normal: bool = True   # distance along the normal (false: along the ray)
    # Gaussian kernels on an update's weight: of the angle between normal and ray, and of the
    # signed distance of the cell from the hit
    update_weight_angle_scan_normal_to_ray_kernel_bandwidth: float = 0.5   # rad; 0 = off
    update_weight_distance_cell_to_hit_kernel_bandwidth: float = 0.5       # m; 0 = off

    def __post_init__(self):
        _positive(self, "truncation_distance", "maximum_weight", "num_normal_samples", "sample_radius")
        for n in ("update_weight_angle_scan_normal_to_ray_kernel_bandwidth",
                  "update_weight_distance_cell_to_hit_kernel_bandwidth"):
            if getattr(self, n) < 0:
                raise ValueError(f"{n} must be >= 0, got {getattr(self, n)}")


@dataclass(frozen=True)
class SubmapsConfig:
    """TRAJECTORY_BUILDER_2D.submaps: TSDF or probability-grid submaps, two active at a time."""

    num_range_data: int = 90
    resolution: float = 0.05                 # grid_options_2d.resolution, m
    # grid_options_2d.grid_type: "tsdf" (ours as default; Cartographer's TSDF option) or
    # "probability_grid" (Cartographer's default). The probability grid puts a wall at the
    # centres of its hit cells, up to half a cell off, and its matches carry that bias: with the
    # submap built at the true poses, a scan matched from its true pose lands 10-14 mm behind
    # it and 0.1-0.3 deg off (realistic noise, seed 0, bench_scripts/matcher_bias.py)
    grid_type: str = "tsdf"
    tsdf: TsdfInserterConfig = field(default_factory=TsdfInserterConfig)
    # probability_grid only:
    hit_probability: float = 0.55            # range_data_inserter.probability_grid_inserter_options_2d
    miss_probability: float = 0.49
    insert_free_space: bool = True
    hit_near_range: float = 0.0              # ours: > 0 scales the hit odds by min(1, (this / range)^2)
    min_probability: float = 0.1             # Cartographer's kMinProbability / kMaxProbability clamp
    max_probability: float = 0.9
    # ours: a hit ray frees space only up to this many range sigmas short of the hit (0 = up to
    # the hit cell, as Cartographer); the band is marked observed, not free. With the LDS-01's
    # range noise, free-space updates from the short beams erode a wall's front and leave its
    # mapped surface behind the true one, more so where it was seen from far: submaps bend,
    # and scans matched into them drift in heading
    free_space_margin_sigmas: float = 1.5
    # the lidar's range noise, 1 sigma = max(range_sigma_min, range_sigma_ratio * range): the
    # LDS-01 datasheet's +-15 mm below 0.5 m and +-5 % beyond, read as 2-sigma bounds
    range_sigma_min: float = 0.0075          # m
    range_sigma_ratio: float = 0.025

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

    min_range: float = 0.12                  # TB3
    max_range: float = 3.5                   # TB3
    missing_data_ray_length: float = 3.0     # TB3; no-return beams free space up to this range
    voxel_filter_size: float = 0.025
    # ours, a switch: Cartographer's voxel filters keep a random point of each voxel
    # (RandomizedVoxelFilter); false keeps the first, which favours the first beams of the
    # sweep and turns every matched scan slightly (corridor: +0.15 -> +0.08 deg, matcher_bias.py)
    randomized_voxel_filter: bool = True
    use_imu_data: bool = True                # TB3: yaw rate from the gyro in the extrapolator
    use_odometry: bool = True                # cartographer_ros options.use_odometry (TB3: false
                                             # with the LDS only; the simulated robot has wheels)
    use_online_correlative_scan_matching: bool = False  # Cartographer default (TB3: true; its
                                             # 1-cell / 0.8 deg lattice then anchors the rotation)
    deskew: bool = True                      # ours: undo motion during the 0.2 s revolution
    ignore_unknown_points: bool = True       # ours: points landing in never-observed cells get no
                                             # weight (else the edge of the known map pulls them back)
    match_near_range: float = 1.0            # ours: > 0 weights each point in the least squares by
                                             # min(1, (match_near_range / range)^2); 0 = uniform
    motion_filter: MotionFilterConfig = field(default_factory=MotionFilterConfig)
    adaptive_voxel_filter: AdaptiveVoxelConfig = field(default_factory=AdaptiveVoxelConfig)
    real_time_correlative_scan_matcher: RealTimeCorrelativeConfig = field(
        default_factory=RealTimeCorrelativeConfig)
    # ours: translation_weight 100 instead of 10: along a corridor the grid pins nothing and the
    # least squares drifted back by ~1 % of the distance driven; the odometry prediction does better
    ceres_scan_matcher: CeresScanMatcherConfig = field(
        default_factory=lambda: CeresScanMatcherConfig(translation_weight=100.0))
    submaps: SubmapsConfig = field(default_factory=SubmapsConfig)

    def __post_init__(self):
        _positive(self, "max_range", "voxel_filter_size")


@dataclass(frozen=True)
class FastCorrelativeConfig:
    """POSE_GRAPH.constraint_builder.fast_correlative_scan_matcher (branch and bound)."""

    linear_search_window: float = 1.0        # ours (Cartographer 7 m): drift in these worlds stays
                                             # well below 1 m, and 7 m finds the ring's other sides
    angular_search_window: float = math.radians(30.0)
    branch_and_bound_depth: int = 7


@dataclass(frozen=True)
class ConstraintBuilderConfig:
    """POSE_GRAPH.constraint_builder: loop-closure search between nodes and finished submaps."""

    sampling_ratio: float = 0.3
    max_constraint_distance: float = 15.0
    min_score: float = 0.65                  # TB3 (Cartographer default 0.55)
    loop_closure_translation_weight: float = 1.1e4
    loop_closure_rotation_weight: float = 1e5
    min_information_ratio: float = 0.1       # ours: reject matches this degenerate (0 = off)
    ambiguity_radius: float = 0.3            # ours: reject a match when a pose this far (m) from it
    ambiguity_margin: float = 0.02           # scores within this margin of the best (0 radius = off)
    # ours: reject a match when more than this fraction of its points have space the submap knows
    # to be free (probability below see_through_free_probability) one submap cell beyond them
    # along the beam: the scan would see through a surface. This is the far face of a thin wall,
    # mapped from its other side, that a hit-only score cannot tell from the near face (0 = off)
    max_see_through_ratio: float = 0.05
    see_through_free_probability: float = 0.3
    fast_correlative_scan_matcher: FastCorrelativeConfig = field(default_factory=FastCorrelativeConfig)
    ceres_scan_matcher: CeresScanMatcherConfig = field(default_factory=lambda: CeresScanMatcherConfig(
        occupied_space_weight=20.0, translation_weight=10.0, rotation_weight=1.0, max_num_iterations=10))
    loop_closure_adaptive_voxel_filter: AdaptiveVoxelConfig = field(
        default_factory=lambda: AdaptiveVoxelConfig(max_length=0.9, min_num_points=100))

    def __post_init__(self):
        if not 0.0 <= self.max_see_through_ratio <= 1.0:
            raise ValueError(f"max_see_through_ratio must lie in [0, 1], got {self.max_see_through_ratio}")
        if not 0.0 < self.see_through_free_probability < 1.0:
            raise ValueError(f"see_through_free_probability must lie in (0, 1), "
                             f"got {self.see_through_free_probability}")


@dataclass(frozen=True)
class OptimizationConfig:
    """POSE_GRAPH.optimization_problem: sparse pose adjustment."""

    # Ours 1 (Cartographer 1e1). On probability-grid submaps the closures were biased by 1-3 cm
    # and 0.3-0.5 deg and only 0.1 kept them from bending the trajectory; on TSDF submaps they
    # are precise enough to act. On the seed-0 logs 0.1 and 1 score within 0.01 of each other;
    # on seed 1 (seen when choosing) 1 closes the loop world (P 0.78 -> 0.99), and on seed 2
    # (checked after) it is better on every world with loops (loop 0.74 -> 0.83, rectangle_l
    # 0.66 -> 0.76). 10 scores lower on corridor, loop and the swirls on seeds 0 and 1.
    huber_scale: float = 1.0
    # At 1e5 the chain of consecutive nodes is so stiff that Huber-capped loop closures hardly
    # move it; 1e3 lets them act, but the imprecise closures on these blurred (LDS-01) submaps
    # then cost more than they gain (swirl_s P 0.995 -> 0.88), so Cartographer's value stays.
    local_slam_pose_translation_weight: float = 1e5
    local_slam_pose_rotation_weight: float = 1e5
    # Weights of the wheel odometry between consecutive nodes (Cartographer 1e5 / 1e5; its pose
    # graph gets odometry whenever cartographer_ros' use_odometry is on, which the TurtleBot3
    # configuration turns off). Ours 0 = no odometry constraint: the odometry drifts by a few
    # per cent and at 1e5 beside the local-SLAM chain it outweighs the loop closures (seed-0
    # loop world P/S 0.945/1.000 -> 0.389/0.510, rectangle_l 0.922/0.921 -> 0.535/0.639; the
    # CSAIL hold-out 0.773 -> 1.484 m). Here, unlike Cartographer, the odometry only predicts.
    odometry_translation_weight: float = 0.0
    odometry_rotation_weight: float = 0.0
    max_num_iterations: int = 50             # ceres_solver_options.max_num_iterations
    max_loop_residual: float = 0.25          # ours: loop closures off by more (m) after optimizing
                                             # are dropped and the problem solved again (0 = keep all)
    solver: str = "lm"                       # ours: "lm" sparse Levenberg-Marquardt on the normal
                                             # equations (Ceres' SPARSE_NORMAL_CHOLESKY), "trf" scipy


@dataclass(frozen=True)
class GlobalConfig:
    """POSE_GRAPH: loop closure and optimization."""

    enable_loop_closure: bool = True         # ours: false = no constraint search (local SLAM + SPA)
    optimize_every_n_nodes: int = 90
    matcher_translation_weight: float = 5e2  # weights of the intra-submap (local) constraints
    matcher_rotation_weight: float = 1.6e3
    constraint_builder: ConstraintBuilderConfig = field(default_factory=ConstraintBuilderConfig)
    optimization_problem: OptimizationConfig = field(default_factory=OptimizationConfig)


@dataclass(frozen=True)
class GraphConfig:
    """The pose-graph SLAM: local SLAM (trajectory_builder) + global SLAM (pose_graph)."""

    trajectory_builder: LocalConfig = field(default_factory=LocalConfig)
    pose_graph: GlobalConfig = field(default_factory=GlobalConfig)
    map_resolution: float = 0.05             # ours: resolution of the final composed map, m
    final_map: str = "sharpened"             # ours: "probability" (submap odds), "sharpened"
                                             # (see slam/graph/final_map.py) or "mapper" (every
                                             # scan at its optimized pose into `output_map`, the
                                             # shared output map of oracle and gn)
    output_map: MapperConfig = field(default_factory=MapperConfig)  # ours: used by final_map "mapper"
    map_near_range: float = 0.5              # ours, sharpened: rays up to this range weigh 1
    map_suppress_ratio: float = 0.4          # ours, sharpened: 3x3 non-maximum suppression ratio
    map_max_range: float = 2.0               # ours: hits farther than this (m) from the lidar are
                                             # left out of the final map (0 = all): the LDS-01's
                                             # error grows with range (5 % beyond 0.5 m); 2 m as
                                             # the shared output map (slam.mapper) the oracle uses

    def __post_init__(self):
        if self.final_map not in ("probability", "sharpened", "mapper"):
            raise ValueError(f"final_map must be 'probability', 'sharpened' or 'mapper', "
                             f"got {self.final_map!r}")
        _positive(self, "map_resolution", "map_near_range")
