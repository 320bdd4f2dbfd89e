"""Running a SLAM: replay a sensor log into it, one scan at a time, and time every update.

Per scan the algorithm gets the odometry pose interpolated at the scan's time (with the
previous scan's), the IMU samples since the previous scan and, for an algorithm that
`uses_ground_truth`, the true pose.
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np

from worlds.yamlio import InputError, to_dict
from sim.logs import SensorLog
from slam.registry import get as get_algorithm, load_config
from slam.base import ImuWindow, OdomDelta, Scan, Slam, SlamResult
from slam.pose import interpolate_poses
from slam.range_noise import range_noise_from_meta

__all__ = ["run", "run_algorithm", "scans_of"]


def scans_of(log: SensorLog) -> list[Scan]:
    """The log's scans as the SLAMs get them (N Scan objects, in time order): ranges, angles,
    range limits, lidar offset, time between beams and index from the log and its meta."""
    lidar = log.meta.get("lidar", {})
    offset = log.lidar_offset
    time_inc = float(lidar.get("time_increment", 0.0))
    noise = range_noise_from_meta(log.meta)
    return [Scan(float(t), log.scan_ranges[i], log.scan_angles, log.range_min, log.range_max,
                 offset, time_inc, i, noise) for i, t in enumerate(log.scan_t)]


def _iter_inputs(log: SensorLog):
    """Yield (scan, odom, imu, true_pose) for every scan of the log, in time order."""
    scans = scans_of(log)
    # the revolution's last beam: its odometry and gyro come with the scan
    sweep_end_t = log.scan_t + np.array([s.sweep_time for s in scans])
    timed = sweep_end_t > log.scan_t
    odom_at = odom_end = None
    if log.has_odometry:
        odom_at = interpolate_poses(log.scan_t, log.odom_t, log.odom_pose)
        odom_end = interpolate_poses(sweep_end_t, log.odom_t, log.odom_pose)
        timed_odom = timed & (sweep_end_t <= log.odom_t[-1])
    gt_at = interpolate_poses(log.scan_t, log.gt_t, log.gt_pose) if log.has_ground_truth else None
    imu_idx = np.searchsorted(log.imu_t, log.scan_t, side="right") if log.has_imu else None
    imu_end = np.searchsorted(log.imu_t, sweep_end_t, side="right") if log.has_imu else None
    for i, scan in enumerate(scans):
        t = scan.t
        odom = None
        if odom_at is not None:
            odom = OdomDelta(odom_at[i], odom_at[i - 1] if i > 0 else odom_at[i],
                             odom_end[i] if timed_odom[i] else None)
        imu = None
        if imu_idx is not None:
            lo = imu_idx[i - 1] if i > 0 else np.searchsorted(log.imu_t, t - 0.2, side="right")
            hi = imu_idx[i]
            sweep = log.imu_gyro[hi:imu_end[i]] if timed[i] else log.imu_gyro[:0]
            imu = ImuWindow(log.imu_t[lo:hi], log.imu_gyro[lo:hi], log.imu_accel[lo:hi], log.imu_yaw[lo:hi],
                            sweep)
        yield scan, odom, imu, (gt_at[i] if gt_at is not None else None)


def run(slam: Slam, log: SensorLog) -> SlamResult:
    """Replay `log` into `slam`, time every update, call finish(); return the SlamResult."""
    if log.n_scans == 0:
        raise InputError("log has no scans")
    finite = np.isfinite(log.scan_ranges) & (log.scan_ranges > 0)
    if not finite.any():
        raise InputError("log has no finite range reading in any scan (all beams inf or NaN)")
    if slam.needs_odometry and not log.has_odometry:
        raise InputError(f"algorithm '{slam.name}' needs wheel odometry, but the log has none")
    truth_fed = slam.uses_ground_truth
    if truth_fed and not log.has_ground_truth:
        raise InputError(f"algorithm '{slam.name}' maps with true poses, but the log has no ground truth")
    t0 = time.perf_counter()
    update_times = []
    for scan, odom, imu, truth in _iter_inputs(log):
        u0 = time.perf_counter()
        try:
            pose = (slam.update(scan, odom, imu, truth=truth) if truth_fed
                    else slam.update(scan, odom, imu))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
            # numbers gone wrong (a config value out of range, a diverged estimate): a failed
            # run, reported in one line, not a crash
            raise InputError(f"algorithm '{slam.name}' failed at scan {scan.index} "
                             f"(t = {scan.t:.3f} s): {type(err).__name__}: {err}") from err
        if not np.all(np.isfinite(pose)):
            raise InputError(f"algorithm '{slam.name}' gave a non-finite pose at scan {scan.index} "
                             f"(t = {scan.t:.3f} s): {pose}")
        update_times.append(time.perf_counter() - u0)
    f0 = time.perf_counter()
    slam.finish()
    finish_time = time.perf_counter() - f0
    grid = slam.map()
    times, poses = slam.trajectory()
    wall = time.perf_counter() - t0
    duration = log.duration
    stats = {
        "wall_time_s": wall,
        "scans_processed": int(log.n_scans),
        "log_duration_s": duration,
        "realtime_factor": duration / wall if wall > 0 else float("inf"),
        "update_time_median_s": float(np.median(update_times)),
        "update_time_max_s": float(np.max(update_times)),
        "finish_time_s": finish_time,
    }
    stats.update(slam.extra_stats())
    return SlamResult(grid, times, poses, stats, to_dict(slam.config))


def run_algorithm(name: str, log: SensorLog, config: Any = None, seed: int = 0) -> SlamResult:
    """Build algorithm `name` with `config` (None, mapping or YAML path, over the values it
    derives from the log; a config dataclass as it is) and seed, and run it on `log`."""
    cls = get_algorithm(name)
    cfg = load_config(name, config, log=log)
    slam = cls(cfg, log.start_pose.copy(), np.random.default_rng(seed))
    result = run(slam, log)
    result.stats.update({"algo": name, "seed": int(seed)})
    return result
