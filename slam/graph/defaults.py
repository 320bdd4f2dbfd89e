"""graph's config values that follow from the log's sensors (GraphSlam.derive_config).

Each rule gives GraphConfig's TurtleBot3 values on a simulated LDS-01 log (5 Hz, 360 beams,
0.12-3.5 m, +-5 % noise, wheel odometry and IMU, a few centimetres between scans); on other
logs it gives what Cartographer's options mean for that sensor and that log's scan spacing.
"""
from __future__ import annotations

import math

from slam.graph.config import CeresScanMatcherConfig, LocalConfig
from slam.sensors import REFERENCE_RATE, Derived, SensorFacts

__all__ = ["derive_graph_config", "SPARSE_STEP"]

# Cartographer's ceres scan matcher (the config class's own defaults): its pulls to the prediction
CARTOGRAPHER_CSM = CeresScanMatcherConfig()

# consecutive scans farther apart than this (m, by odometry) come from a thinned log (a .gfs
# keeps a scan per metre): the scan-to-scan prediction is coarse
SPARSE_STEP = 0.1


def _sig(v: float) -> float:
    """v to four significant digits (a derived value reads as the rule's number)."""
    return float(f"{v:.4g}")


def derive_graph_config(s: SensorFacts) -> list[Derived]:
    """graph's sensor-dependent values from `s`."""
    tb = "trajectory_builder."
    sparse = (not s.odometry) or s.scan_step > SPARSE_STEP
    out = [
        Derived(tb + "min_range", s.range_min, "the sensor's range_min"),
        Derived(tb + "max_range", s.range_max, "the sensor's range_max"),
        Derived(tb + "missing_data_ray_length", min(5.0, max(0.0, s.range_max - 0.5)),
                "no-return beams free space to 0.5 m short of the range limit, at most "
                "Cartographer's 5 m"),
        Derived(tb + "adaptive_voxel_filter.max_range", max(50.0, s.range_max),
                "Cartographer's 50 m, or the range limit when larger"),
        Derived(tb + "use_imu_data", bool(s.imu), "the gyro's yaw rate when the log has an IMU"),
        Derived(tb + "use_online_correlative_scan_matching", bool(sparse),
                f"on when the log has no odometry or its scans are more than {SPARSE_STEP} m "
                f"apart (median {s.scan_step:.3f} m): the prediction is then coarse"),
        Derived(tb + "motion_filter.max_angle_radians",
                math.radians(0.1 * max(1.0, s.scan_rate / REFERENCE_RATE)),
                f"0.1 degree at {REFERENCE_RATE:g} Hz, scaled with the scan rate "
                f"({s.scan_rate:.1f} Hz) so a turn keeps as many nodes"),
    ]
    if not sparse:
        # the prediction (odometry and gyro since the last scan) errs as a random walk: its sigma
        # grows as the square root of the scan interval, so its weight per scan (1 / sigma) as
        # the square root of the rate
        gain = math.sqrt(max(1.0, s.scan_rate / REFERENCE_RATE))
        csm = LocalConfig().ceres_scan_matcher
        why = (f"the value at {REFERENCE_RATE:g} Hz times the square root of the scan rate's "
               f"ratio to it ({s.scan_rate:.1f} Hz): the prediction's error over one scan "
               "interval grows as its square root")
        out += [Derived(tb + "ceres_scan_matcher.translation_weight",
                        _sig(csm.translation_weight * gain), why),
                Derived(tb + "ceres_scan_matcher.rotation_weight",
                        _sig(csm.rotation_weight * gain), why)]
    if not s.odometry:
        # the class's pulls trust a wheel-odometry prediction; a constant-velocity guess earns
        # only Cartographer's, and the tuned ones drag every scan towards it
        why = ("Cartographer's pull to the prediction when the log has no odometry (the "
               "prediction is the last motion, continued)")
        out += [Derived(tb + "ceres_scan_matcher.translation_weight", CARTOGRAPHER_CSM.translation_weight, why),
                Derived(tb + "ceres_scan_matcher.rotation_weight", CARTOGRAPHER_CSM.rotation_weight, why)]
    nodes = 90 if not sparse or s.scan_step <= 0 else max(30, min(90, round(30.0 / s.scan_step)))
    thinned = s.odometry and s.scan_step > SPARSE_STEP
    out.append(Derived(tb + "real_time_correlative_scan_matcher.linear_search_window",
                       0.2 if thinned else 0.1,
                       "0.1 m; 0.2 m on a thinned log, about the odometry error over a metre"))
    if thinned:
        # a log that kept one scan per metre or so (GMapping's .gfs, its linearUpdate) records a
        # building-scale route with scans too far apart for the room-scale TurtleBot3 values:
        # Cartographer's own values, and submaps coarse enough to match sparse far returns
        why = (f"Cartographer's value on a thinned log (scans {s.scan_step:.2f} m apart by "
               "odometry: a building-scale route)")
        out += [Derived("pose_graph.constraint_builder.fast_correlative_scan_matcher."
                        "linear_search_window", 7.0, why),
                Derived("pose_graph.constraint_builder.min_score", 0.55, why),
                Derived("pose_graph.optimization_problem.huber_scale", 10.0, why),
                Derived("pose_graph.optimization_problem.max_loop_residual", 0.0,
                        "keep every loop closure, as Cartographer, on a thinned log"),
                Derived("pose_graph.optimization_problem.local_slam_pose_translation_weight",
                        1e4, "the local-SLAM chain held less stiffly on a thinned log"),
                Derived("pose_graph.optimization_problem.local_slam_pose_rotation_weight",
                        1e4, "the local-SLAM chain held less stiffly on a thinned log"),
                Derived(tb + "ceres_scan_matcher.translation_weight", CARTOGRAPHER_CSM.translation_weight, why),
                Derived(tb + "randomized_voxel_filter", False,
                        "a voxel keeps its first point on a thinned log"),
                Derived(tb + "submaps.grid_type", "probability_grid", why),
                Derived(tb + "submaps.resolution", 0.1,
                        "0.1 m cells on a thinned log: scans a metre apart leave 5 cm submaps "
                        "too sparse at range to match against"),
                Derived(tb + "submaps.free_space_margin_sigmas", 0.0,
                        "rays free space up to their hit on a thinned log")]
    out.append(Derived(tb + "submaps.num_range_data", int(nodes),
                       "90 scans (Cartographer's); from a thinned log, about 30 m of travel, at "
                       "least 30"))
    out.append(Derived("pose_graph.optimize_every_n_nodes", int(nodes), "once per submap"))
    noise = s.range_noise
    out.append(Derived(tb + "submaps.range_sigma_min", _sig(float(noise.sigma(max(s.range_min, 0.0)))),
                       "the range noise model's sigma at range_min"))
    out.append(Derived(tb + "submaps.range_sigma_ratio",
                       _sig(float(noise.sigma(s.range_max)) / s.range_max)
                       if math.isfinite(s.range_max) and s.range_max > 0 else 0.025,
                       "the range noise model's sigma at range_max, over range_max"))
    return out
