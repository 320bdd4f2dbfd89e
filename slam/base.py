"""The SLAM contract (the Slam base class), what it is fed (Scan, OdomDelta, ImuWindow) and
what a run produces (SlamResult). slam.replay feeds a log into it; slam.registry names it.

Every algorithm is built as `Algo(config, start, rng)` (start: the log's initial pose, the
only ground truth it sees) and fed one scan at a time.

Scan timing convention: `scan_t[i]` is the time of the first beam of revolution i; beam j
is taken at scan_t[i] + j * meta.lidar.time_increment (0 when the log has no such field).
The pose a SLAM returns for a scan is the robot (base) pose at scan_t[i]. A scan reaches a
real-time SLAM when its revolution ends, so the odometry and IMU of the revolution come with
it (`OdomDelta.sweep_end`, `ImuWindow.sweep_gyro`).
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field, is_dataclass
from typing import ClassVar

import numpy as np

from worlds.grid import Grid
from slam.pose import relative
from slam.range_noise import DEFAULT_RANGE_NOISE, RangeNoise

__all__ = ["Scan", "OdomDelta", "ImuWindow", "Slam", "SlamResult", "check_algorithm_class"]


@dataclass(frozen=True, eq=False)
class Scan:
    """One lidar revolution as recorded (nothing dropped yet).

    t: s (first beam); ranges: (B,) m, inf = no return; angles: (B,) rad in the lidar frame;
    offset: (3,) lidar pose in the robot frame; time_increment: s between beams;
    range_noise: the sensor's range error model (the output map weighs hits by it).
    """

    t: float
    ranges: np.ndarray
    angles: np.ndarray
    range_min: float
    range_max: float
    offset: np.ndarray
    time_increment: float = 0.0
    index: int = 0
    range_noise: RangeNoise = DEFAULT_RANGE_NOISE

    @property
    def sweep_time(self) -> float:
        """s from the first beam to the last (0 without beam timing)."""
        return self.time_increment * max(len(self.ranges) - 1, 0)


@dataclass(frozen=True, eq=False)
class OdomDelta:
    """Wheel odometry at this scan and the previous one (odometry frame poses, (3,) each), and
    at the scan's last beam (sweep_end: None when the odometry ends before it or the scan has
    no beam timing)."""

    pose: np.ndarray
    prev_pose: np.ndarray
    sweep_end: np.ndarray | None = None

    @property
    def delta(self) -> np.ndarray:
        """(3,) motion since the previous scan in the robot frame at the previous scan."""
        return relative(self.prev_pose, self.pose)


@dataclass(frozen=True, eq=False)
class ImuWindow:
    """IMU samples in (previous scan time, this scan time]: t (K,), gyro (K,) rad/s,
    accel (K, 2) m/s^2, yaw (K,) rad (integrated, as the TurtleBot3 IMU reports); and the gyro
    samples (rad/s) taken during the scan's revolution, (this scan time, its last beam]."""

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    yaw: np.ndarray
    sweep_gyro: np.ndarray = field(default_factory=lambda: np.zeros(0))


class Slam(ABC):
    """A 2D SLAM fed one scan at a time, from the log's initial pose (the algorithm contract).

    A subclass sets `name` and `config_class` (a frozen dataclass, loaded from YAML), and
    describes itself by class attributes, each with a default a plugin may keep:
    needs_odometry: the log must have wheel odometry;
    uses_ground_truth: update() receives the true pose as `truth=` (the oracle): the benchmark
        shows it as the ceiling, last, and reads the others' gap to it;
    family: the reference study's algorithm it stands beside ("Gmapping", "Hector",
        "Cartographer"; bench.study), None for none;
    warmup_scans: how many scans the benchmark's untimed warm-up run needs to reach every
        compiled kernel once;
    compile_cost_s: the cold compile time of its own kernels, s (the output map and the
        metrics every algorithm shares not counted; a rough figure: the benchmark sends the
        compile jobs out heaviest first so the workers finish them together);
    deterministic: its output does not depend on the seed of `rng`: the benchmark runs it once
        per log and gives the repeats that differ only in the SLAM seed that run's row.
    It is built as `Cls(config, start, rng)`; `self.config` is what config.yaml records. What
    depends on the sensor (ranges, beam spacing, rates) it derives from the log in
    `derive_config`.
    """

    name: ClassVar[str] = ""
    config_class: ClassVar[type]
    needs_odometry: ClassVar[bool] = False
    uses_ground_truth: ClassVar[bool] = False
    family: ClassVar[str | None] = None
    warmup_scans: ClassVar[int] = 12
    compile_cost_s: ClassVar[float] = 0.0
    deterministic: ClassVar[bool] = False

    def __init__(self, config, start: np.ndarray, rng: np.random.Generator):
        self.config = config
        self.rng = rng

    @abstractmethod
    def update(self, scan: Scan, odom: OdomDelta | None, imu: ImuWindow | None) -> np.ndarray:
        """Take one scan (and the odometry and IMU since the last); return the pose (3,)."""

    @abstractmethod
    def map(self) -> Grid:
        """The output map."""

    @abstractmethod
    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """Times (N,) and poses (N, 3), one per scan."""

    @classmethod
    def derive_config(cls, sensors) -> list:
        """The config values this algorithm takes from the log's sensors (a
        slam.sensors.SensorFacts), as slam.sensors.Derived records; a value the user's config
        sets wins over them. The default: none."""
        return []

    def finish(self) -> None:
        """Called once after the last scan (a final optimization, say)."""

    def extra_stats(self) -> dict:
        """Algorithm-specific numbers for stats.json."""
        return {}


def check_algorithm_class(cls: type, name: str = "") -> None:
    """Raise TypeError unless `cls` implements the Slam contract (subclass, config dataclass,
    the abstract methods) and its describing attributes have the types Slam documents."""
    label = name or getattr(cls, "__name__", repr(cls))
    if not (isinstance(cls, type) and issubclass(cls, Slam)):
        raise TypeError(f"algorithm '{label}' is not a subclass of slam.base.Slam")
    if not is_dataclass(getattr(cls, "config_class", None)):
        raise TypeError(f"algorithm '{label}': config_class must be a dataclass")
    missing = sorted(getattr(cls, "__abstractmethods__", ()))
    if missing:
        raise TypeError(f"algorithm '{label}' does not implement {', '.join(missing)}")
    for attr in ("needs_odometry", "uses_ground_truth", "deterministic"):
        if not isinstance(getattr(cls, attr), bool):
            raise TypeError(f"algorithm '{label}': {attr} must be True or False, "
                            f"got {getattr(cls, attr)!r}")
    if cls.family is not None and not (isinstance(cls.family, str) and cls.family):
        raise TypeError(f"algorithm '{label}': family must be a name or None, got {cls.family!r}")
    warmup = cls.warmup_scans
    if isinstance(warmup, bool) or not isinstance(warmup, int) or warmup < 1:
        raise TypeError(f"algorithm '{label}': warmup_scans must be an integer >= 1, got {warmup!r}")
    cost = cls.compile_cost_s
    if isinstance(cost, bool) or not isinstance(cost, (int, float)) or not 0 <= cost < float("inf"):
        raise TypeError(f"algorithm '{label}': compile_cost_s must be a number of seconds >= 0, "
                        f"got {cost!r}")


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
