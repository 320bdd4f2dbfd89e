"""SensorLog: the recorded sensor data every SLAM consumes, with the rules its arrays' shapes
follow; the file it is kept in is sim.logs.npz (docs/formats.md).

Arrays: scan_t (N), scan_ranges (N x beams, inf = no return), scan_angles (beams),
odom_t (M), odom_pose (M x 3), odom_twist (M x 2: v, w), imu_t (K), imu_gyro (K),
imu_accel (K x 2), imu_yaw (K), gt_t (L), gt_pose (L x 3).
A real log may lack odometry, IMU or ground truth (empty arrays).

meta keys written by the simulator: format_version, world, seed, noise (profile name and
numbers), lidar ({range_min, range_max, offset: [x, y, yaw] of the lidar in the robot frame,
scan_time, ...}), robot ({wheel_radius, wheel_separation, ...}), start_pose [x, y, yaw],
sim_version, and how the recording went: ending (end | stuck | time limit), route_length,
route_driven, wall_coverage (sim.record). Importers of real logs write what they know.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sim.logs.checks import log_problem

__all__ = ["SensorLog", "ARRAYS", "shape_problem", "value_problem", "world_ref"]

# name -> trailing shape (None = the length axis); the length axis is shared per group
ARRAYS = {
    "scan_t": (), "scan_ranges": ("beams",), "scan_angles": None,
    "odom_t": (), "odom_pose": (3,), "odom_twist": (2,),
    "imu_t": (), "imu_gyro": (), "imu_accel": (2,), "imu_yaw": (),
    "gt_t": (), "gt_pose": (3,),
}
_GROUPS = {"scan": ["scan_t", "scan_ranges"], "odom": ["odom_t", "odom_pose", "odom_twist"],
           "imu": ["imu_t", "imu_gyro", "imu_accel", "imu_yaw"], "gt": ["gt_t", "gt_pose"]}


def _empty(name: str) -> np.ndarray:
    tail = ARRAYS[name]
    if tail is None or tail == () or tail == ("beams",):
        return np.zeros((0,) if tail != ("beams",) else (0, 0))
    return np.zeros((0, *tail))


@dataclass(frozen=True, eq=False)
class SensorLog:
    """Recorded sensor data; arrays as in the module docstring, times in seconds."""

    scan_t: np.ndarray
    scan_ranges: np.ndarray
    scan_angles: np.ndarray
    odom_t: np.ndarray = field(default_factory=lambda: _empty("odom_t"))
    odom_pose: np.ndarray = field(default_factory=lambda: _empty("odom_pose"))
    odom_twist: np.ndarray = field(default_factory=lambda: _empty("odom_twist"))
    imu_t: np.ndarray = field(default_factory=lambda: _empty("imu_t"))
    imu_gyro: np.ndarray = field(default_factory=lambda: _empty("imu_gyro"))
    imu_accel: np.ndarray = field(default_factory=lambda: _empty("imu_accel"))
    imu_yaw: np.ndarray = field(default_factory=lambda: _empty("imu_yaw"))
    gt_t: np.ndarray = field(default_factory=lambda: _empty("gt_t"))
    gt_pose: np.ndarray = field(default_factory=lambda: _empty("gt_pose"))
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        for name in ARRAYS:
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=np.float64))
        problem = shape_problem({n: getattr(self, n) for n in ARRAYS})
        if problem:
            raise ValueError(f"SensorLog: {problem}")

    # --- derived -----------------------------------------------------------------------
    @property
    def n_scans(self) -> int:
        return len(self.scan_t)

    @property
    def duration(self) -> float:
        """Seconds from the first to the last scan (0 for fewer than two scans)."""
        return float(self.scan_t[-1] - self.scan_t[0]) if self.n_scans > 1 else 0.0

    @property
    def has_odometry(self) -> bool:
        return len(self.odom_t) > 0

    @property
    def has_imu(self) -> bool:
        return len(self.imu_t) > 0

    @property
    def has_ground_truth(self) -> bool:
        return len(self.gt_t) > 0

    @property
    def start_pose(self) -> np.ndarray:
        """(3,) the pose a SLAM starts at: meta start_pose, else the first true pose, else 0."""
        if "start_pose" in self.meta and self.meta["start_pose"] is not None:
            return np.asarray(self.meta["start_pose"], dtype=np.float64)
        if self.has_ground_truth:
            return self.gt_pose[0].copy()
        return np.zeros(3)

    @property
    def lidar_offset(self) -> np.ndarray:
        """(3,) pose x, y, yaw of the lidar in the robot (base) frame."""
        off = self.meta.get("lidar", {}).get("offset", [0.0, 0.0, 0.0])
        return np.asarray(off, dtype=np.float64)

    @property
    def range_min(self) -> float:
        return float(self.meta.get("lidar", {}).get("range_min", 0.0))

    @property
    def range_max(self) -> float:
        return float(self.meta.get("lidar", {}).get("range_max", np.inf))


def shape_problem(arrays: dict[str, np.ndarray]) -> str | None:
    """None if the arrays (by name, as ARRAYS) have consistent shapes, else a description of
    the first problem."""
    beams = arrays["scan_angles"]
    if beams.ndim != 1:
        return f"scan_angles must be 1-D, got shape {beams.shape}"
    for group, names in _GROUPS.items():
        n = None
        for name in names:
            a = arrays[name]
            tail = ARRAYS[name]
            want_tail = (len(beams),) if tail == ("beams",) else tail
            if a.size == 0 and group != "scan":
                continue  # an absent sensor: any empty shape is accepted
            if a.ndim != 1 + len(want_tail) or tuple(a.shape[1:]) != tuple(want_tail):
                if not (group == "scan" and a.size == 0 and len(beams) == 0):
                    return f"{name} has shape {a.shape}, expected (n, {', '.join(map(str, want_tail))})".replace(", )", ")")
            if n is None:
                n = a.shape[0]
            elif a.shape[0] != n:
                return f"{name} has {a.shape[0]} rows but {names[0]} has {n}"
    return None


def value_problem(log: SensorLog) -> str | None:
    """None if the log's values follow sim.logs.checks' rules, else the first problem."""
    return log_problem({name: getattr(log, name) for name in ARRAYS}, log.meta)


def _under_any(path: Path, roots: list[Path]) -> bool:
    """True when `path` (resolved) lies inside one of the `roots` folders."""
    return any(r.resolve() in path.parents for r in roots)


def world_ref(meta: dict, log_path: str | Path | None = None) -> str | None:
    """The world a recorded log was made in, as `worlds.load_world` takes it: its YAML file
    (meta world_source) or its shipped name (meta world); None when neither can be found (a
    real robot's log).

    A log may come from a stranger, so its world_source is followed only into the log's own
    folder (or below; a file of that name beside the log also counts) and the shipped worlds:
    never to any other file on this machine.
    """
    from worlds.load import list_worlds, world_dir
    src = str(meta.get("world_source") or "")
    if src and Path(src).suffix in (".yaml", ".yml"):
        roots = [world_dir()]
        places = [Path(src)]
        if log_path is not None:
            here = Path(log_path).resolve().parent
            roots.append(here)
            places = [here / src, here / Path(src).name] + places
        for cand in places:
            if cand.is_file() and _under_any(cand.resolve(), roots):
                return str(cand.resolve())
    name = str(meta.get("world") or "")
    return name if name in list_worlds() else None
