"""SensorLog: the recorded sensor data every SLAM consumes, and its versioned .npz file.

File (DESIGN.md): one .npz with a JSON string `meta` and the arrays
scan_t (N), scan_ranges (N x beams, inf = no return), scan_angles (beams),
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

import io
import json
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from worlds.yamlio import InputError, atomic_write_bytes
from sim.logcheck import log_problem

__all__ = ["SensorLog", "read_log", "write_log", "value_problem", "world_ref", "FORMAT_VERSION"]

FORMAT_VERSION = 1
# zlib level of the .npz entries: most arrays are float noise that higher levels barely
# shrink (a few % for 3x the time); np.load reads any level
_DEFLATE_LEVEL = 1
# an entry whose first _PROBE bytes deflate by less than _MIN_GAIN is stored uncompressed
# (white sensor noise: deflating it costs time and saves nothing)
_PROBE = 1 << 14
_MIN_GAIN = 0.05

# name -> trailing shape (None = the length axis); the length axis is shared per group
_ARRAYS = {
    "scan_t": (), "scan_ranges": ("beams",), "scan_angles": None,
    "odom_t": (), "odom_pose": (3,), "odom_twist": (2,),
    "imu_t": (), "imu_gyro": (), "imu_accel": (2,), "imu_yaw": (),
    "gt_t": (), "gt_pose": (3,),
}
_GROUPS = {"scan": ["scan_t", "scan_ranges"], "odom": ["odom_t", "odom_pose", "odom_twist"],
           "imu": ["imu_t", "imu_gyro", "imu_accel", "imu_yaw"], "gt": ["gt_t", "gt_pose"]}


def _empty(name: str) -> np.ndarray:
    tail = _ARRAYS[name]
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
        for name in _ARRAYS:
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=np.float64))
        problem = _shape_problem({n: getattr(self, n) for n in _ARRAYS})
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


def _shape_problem(arrays: dict[str, np.ndarray]) -> str | None:
    """None if the arrays have consistent shapes, else a description of the first problem."""
    beams = arrays["scan_angles"]
    if beams.ndim != 1:
        return f"scan_angles must be 1-D, got shape {beams.shape}"
    for group, names in _GROUPS.items():
        n = None
        for name in names:
            a = arrays[name]
            tail = _ARRAYS[name]
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


def write_log(log: SensorLog, path: str | Path) -> None:
    """Write `log` to an .npz atomically (a Ctrl-C never leaves half a file); a log whose values
    break the rules of sim.logcheck raises InputError naming the file and the first bad value."""
    problem = value_problem(log)
    if problem:
        raise InputError(f"{path}: {problem}")
    meta = dict(log.meta)
    meta["format_version"] = FORMAT_VERSION
    buf = io.BytesIO()
    arrays = {name: getattr(log, name) for name in _ARRAYS}
    # fixed zip timestamps and no compression metadata drift: same data, same bytes
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        entries = [("meta", np.array(json.dumps(meta, sort_keys=True)))] + list(arrays.items())
        for name, arr in entries:
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            npy = io.BytesIO()
            np.lib.format.write_array(npy, np.ascontiguousarray(arr), allow_pickle=False)
            data = npy.getvalue()
            if not _deflates(data):
                info.compress_type = zipfile.ZIP_STORED
            zf.writestr(info, data, compresslevel=_DEFLATE_LEVEL)
    atomic_write_bytes(path, buf.getvalue())


def _deflates(data: bytes) -> bool:
    """Whether deflating `data` is worth it, judged on its first _PROBE bytes."""
    probe = data[:_PROBE]
    return len(zlib.compress(probe, _DEFLATE_LEVEL)) < (1.0 - _MIN_GAIN) * len(probe)


def read_log(path: str | Path) -> SensorLog:
    """Read and check a sensor log; a bad file raises InputError naming it and the problem."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: file not found")
    try:
        with np.load(p, allow_pickle=False) as npz:
            data = {k: npz[k] for k in npz.files}
    except Exception as err:   # any damage numpy's npz/npy parsing can meet
        reason = " ".join(str(err).split()) or type(err).__name__
        raise InputError(f"{p}: not a readable sensor log (.npz): {reason}") from None
    if "meta" not in data:
        raise InputError(f"{p}: not a sensor log: no 'meta' entry")
    try:
        meta = json.loads(str(np.asarray(data["meta"]).reshape(-1)[0]))
    except json.JSONDecodeError as err:
        raise InputError(f"{p}: meta: not valid JSON: {err}") from None
    if not isinstance(meta, dict):
        raise InputError(f"{p}: meta: expected a mapping, got {type(meta).__name__}")
    version = meta.get("format_version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise InputError(f"{p}: meta.format_version: expected an integer >= 1, got {version!r}")
    if version > FORMAT_VERSION:
        raise InputError(f"{p}: meta.format_version: {version} is newer than this reader "
                         f"(reads up to {FORMAT_VERSION}); upgrade the package")
    missing = [n for n in _ARRAYS if n not in data]
    if missing:
        raise InputError(f"{p}: missing arrays: {', '.join(missing)}")
    arrays = {n: np.asarray(data[n], dtype=np.float64) for n in _ARRAYS}
    problem = _shape_problem(arrays) or log_problem(arrays, meta)
    if problem:
        raise InputError(f"{p}: {problem}")
    return SensorLog(**arrays, meta=meta)


def value_problem(log: SensorLog) -> str | None:
    """None if the log's values follow sim.logcheck's rules, else the first problem."""
    return log_problem({name: getattr(log, name) for name in _ARRAYS}, log.meta)


def world_ref(meta: dict, log_path: str | Path | None = None) -> str | None:
    """The world a recorded log was made in, as `worlds.load_world` takes it: its YAML file
    (meta world_source, as given or beside the log) or its shipped name (meta world); None
    when neither can be found (a real robot's log)."""
    from worlds import list_worlds
    src = str(meta.get("world_source") or "")
    places = [Path(src)] + ([Path(log_path).parent / src] if log_path is not None else [])
    for cand in places:
        if src and cand.suffix in (".yaml", ".yml") and cand.is_file():
            return str(cand.resolve())
    name = str(meta.get("world") or "")
    return name if name in list_worlds() else None
