"""The SLAM interface, its result type, the algorithm registry and the one replay loop.

Every algorithm is built as `Algo(config, start, rng)` (start: the log's initial pose, the
only ground truth it sees) and fed one scan at a time by `run(slam, log)`, which replays the
log: the odometry pose interpolated at each scan's time, the IMU samples since the previous
scan, and the wall time of every update.

Scan timing convention: `scan_t[i]` is the time of the first beam of revolution i; beam j
is taken at scan_t[i] + j * meta.lidar.time_increment (0 when the log has no such field).
The pose a SLAM returns for a scan is the robot (base) pose at scan_t[i].
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Protocol

import numpy as np

from worlds.grid import Grid
from worlds.yamlio import InputError, from_dict, load_yaml, to_dict
from sim.log import SensorLog
from slam.pose import interpolate_poses, relative

__all__ = ["Scan", "OdomDelta", "ImuWindow", "Slam", "SlamResult", "ALGORITHMS", "register",
           "run", "run_algorithm", "load_config"]


@dataclass(frozen=True, eq=False)
class Scan:
    """One lidar revolution as recorded (nothing dropped yet).

    t: s (first beam); ranges: (B,) m, inf = no return; angles: (B,) rad in the lidar frame;
    offset: (3,) lidar pose in the robot frame; time_increment: s between beams.
    """

    t: float
    ranges: np.ndarray
    angles: np.ndarray
    range_min: float
    range_max: float
    offset: np.ndarray
    time_increment: float = 0.0
    index: int = 0


@dataclass(frozen=True, eq=False)
class OdomDelta:
    """Wheel odometry at this scan and the previous one (odometry frame poses, (3,) each)."""

    pose: np.ndarray
    prev_pose: np.ndarray

    @property
    def delta(self) -> np.ndarray:
        """(3,) motion since the previous scan in the robot frame at the previous scan."""
        return relative(self.prev_pose, self.pose)


@dataclass(frozen=True, eq=False)
class ImuWindow:
    """IMU samples in (previous scan time, this scan time]: t (K,), gyro (K,) rad/s,
    accel (K, 2) m/s^2, yaw (K,) rad (integrated, as the TurtleBot3 IMU reports)."""

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    yaw: np.ndarray


class Slam(Protocol):
    """A 2D SLAM fed one scan at a time, from the log's initial pose."""

    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None) -> np.ndarray: ...
    def map(self) -> Grid: ...
    def finish(self) -> None: ...
    def trajectory(self) -> tuple[np.ndarray, np.ndarray]: ...  # (times (N,), poses (N, 3))


@dataclass(frozen=True, eq=False)
class SlamResult:
    """What a SLAM run produces: its map, its trajectory (times (N,), poses (N, 3)) and stats."""

    grid: Grid
    times: np.ndarray
    poses: np.ndarray
    stats: dict = field(default_factory=dict)
    config: dict = field(default_factory=dict)

    def __post_init__(self):
        t = np.asarray(self.times, dtype=np.float64).reshape(-1)
        p = np.asarray(self.poses, dtype=np.float64).reshape(-1, 3)
        if len(t) != len(p):
            raise ValueError(f"SlamResult: {len(t)} times but {len(p)} poses")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "poses", p)


# name -> class; each class has `config_class` (a frozen dataclass) and optional
# `needs_odometry` / `needs_ground_truth` flags.
ALGORITHMS: dict[str, type] = {}


def register(name: str) -> Callable[[type], type]:
    """Class decorator: make an algorithm available to `run_algorithm` and `--algo NAME`."""
    def deco(cls: type) -> type:
        ALGORITHMS[name] = cls
        cls.algo_name = name
        return cls
    return deco


def _ensure_builtin_algorithms() -> None:
    import slam.algorithms  # noqa: F401  (registers the built-in algorithms)


def load_config(name: str, config: Any = None):
    """The config dataclass of algorithm `name` from None (defaults), a mapping or a YAML path."""
    cls = ALGORITHMS[name].config_class
    if config is None:
        return cls()
    if isinstance(config, cls):
        return config
    if isinstance(config, Mapping):
        return from_dict(cls, config, where="<config>")
    path = Path(config)
    return from_dict(cls, load_yaml(path), where=str(path))


def _iter_inputs(log: SensorLog):
    """Yield (scan, odom, imu, true_pose) for every scan of the log, in time order."""
    odom_at = (interpolate_poses(log.scan_t, log.odom_t, log.odom_pose)
               if log.has_odometry else None)
    gt_at = interpolate_poses(log.scan_t, log.gt_t, log.gt_pose) if log.has_ground_truth else None
    lidar = log.meta.get("lidar", {})
    offset = log.lidar_offset
    time_inc = float(lidar.get("time_increment", 0.0))
    imu_idx = np.searchsorted(log.imu_t, log.scan_t, side="right") if log.has_imu else None
    for i, t in enumerate(log.scan_t):
        scan = Scan(float(t), log.scan_ranges[i], log.scan_angles, log.range_min, log.range_max,
                    offset, time_inc, i)
        odom = None
        if odom_at is not None:
            odom = OdomDelta(odom_at[i], odom_at[i - 1] if i > 0 else odom_at[i])
        imu = None
        if imu_idx is not None:
            lo = imu_idx[i - 1] if i > 0 else np.searchsorted(log.imu_t, t - 0.2, side="right")
            hi = imu_idx[i]
            imu = ImuWindow(log.imu_t[lo:hi], log.imu_gyro[lo:hi], log.imu_accel[lo:hi], log.imu_yaw[lo:hi])
        yield scan, odom, imu, (gt_at[i] if gt_at is not None else None)


def run(slam, log: SensorLog) -> SlamResult:
    """Replay `log` into `slam`, time every update, call finish(); return the SlamResult."""
    if log.n_scans == 0:
        raise InputError("log has no scans")
    finite = np.isfinite(log.scan_ranges) & (log.scan_ranges > 0)
    if not finite.any():
        raise InputError("log has no finite range reading in any scan (all beams inf or NaN)")
    needs_truth = getattr(slam, "needs_ground_truth", False)
    if needs_truth and not log.has_ground_truth:
        raise InputError(f"algorithm '{getattr(slam, 'algo_name', type(slam).__name__)}' maps with "
                         "true poses, but the log has no ground truth")
    t0 = time.perf_counter()
    update_times = []
    for scan, odom, imu, truth in _iter_inputs(log):
        u0 = time.perf_counter()
        if needs_truth:
            slam.update(scan, odom, imu, truth=truth)
        else:
            slam.update(scan, odom, imu)
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
    stats.update(getattr(slam, "extra_stats", lambda: {})())
    return SlamResult(grid, times, poses, stats, to_dict(getattr(slam, "cfg", {})))


def run_algorithm(name: str, log: SensorLog, config: Any = None, seed: int = 0) -> SlamResult:
    """Build algorithm `name` with `config` (None, mapping or YAML path) and seed, and run it on `log`."""
    _ensure_builtin_algorithms()
    if name not in ALGORITHMS:
        raise InputError(f"unknown algorithm '{name}' (known: {', '.join(sorted(ALGORITHMS))})")
    cls = ALGORITHMS[name]
    if getattr(cls, "needs_odometry", False) and not log.has_odometry:
        raise InputError(f"algorithm '{name}' needs wheel odometry, but the log has none")
    cfg = load_config(name, config)
    rng = np.random.default_rng(seed)
    slam = cls(cfg, log.start_pose.copy(), rng)
    result = run(slam, log)
    result.stats.update({"algo": name, "seed": int(seed)})
    return result
