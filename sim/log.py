"""SensorLog: the recorded sensor data every SLAM consumes, and its versioned .npz file.

File (docs/formats.md): one .npz with a JSON string `meta` and the arrays
scan_t (N), scan_ranges (N x beams, inf = no return), scan_angles (beams),
odom_t (M), odom_pose (M x 3), odom_twist (M x 2: v, w), imu_t (K), imu_gyro (K),
imu_accel (K x 2), imu_yaw (K), gt_t (L), gt_pose (L x 3).
A real log may lack odometry, IMU or ground truth (empty arrays).

meta keys written by the simulator: format_version, world, seed, noise (profile name and
numbers), lidar ({range_min, range_max, offset: [x, y, yaw] of the lidar in the robot frame,
scan_time, ...}), robot ({wheel_radius, wheel_separation, ...}), start_pose [x, y, yaw],
sim_version, and how the recording went: ending (end | stuck | time limit), route_length,
route_driven, wall_coverage (sim.record). Importers of real logs write what they know.

Reading checks each member's declared uncompressed size against its .npy header before any
array is read (a few kB of zip can declare gigabytes): the arrays together may take at most
MAX_LOG_BYTES as float64, meta at most MAX_META_CHARS characters nested MAX_JSON_DEPTH deep.
"""
from __future__ import annotations

import io
import json
import math
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from worlds.yamlio import InputError, atomic_write_bytes, short
from sim.logcheck import log_problem

__all__ = ["SensorLog", "read_log", "write_log", "value_problem", "world_ref", "FORMAT_VERSION",
           "MAX_LOG_BYTES", "MAX_META_CHARS", "MAX_JSON_DEPTH", "parse_json"]

FORMAT_VERSION = 1
# the arrays of one log, as float64: 2 GiB holds an hour of a 1080-beam lidar at 40 Hz
# (1.2 GB) and is some 180 times the largest simulated log (swirl_l, 12 MB)
MAX_LOG_BYTES = 2 * 1024 ** 3
# sensor arrays deflate by less than 10x (the cached logs: 3.5-9x); a large member that
# inflates 200x is a bomb meant to fill memory below MAX_LOG_BYTES
_BOMB_RATIO = 200
_BOMB_MIN_BYTES = 64 * 1024 ** 2
# the simulator writes 1-2 kB of meta; importers a few kB more
MAX_META_CHARS = 1_000_000
# deeper than the YAML cap (64: configs stored in JSON files may reach it), far below
# Python's recursion limit (1000), which deep JSON would otherwise hit in every reader
MAX_JSON_DEPTH = 100
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
    _check_writable_size(log, meta, str(path))
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


def _check_writable_size(log: SensorLog, meta: dict, where: str) -> None:
    """InputError when read_log would refuse the log for its size (MAX_LOG_BYTES,
    MAX_META_CHARS, MAX_JSON_DEPTH): a writer must not make a file its own reader refuses."""
    size = sum(getattr(log, n).nbytes for n in _ARRAYS)
    if size > MAX_LOG_BYTES:
        raise InputError(f"{where}: the log's arrays take {size:,} bytes, more than the "
                         f"{MAX_LOG_BYTES:,} a sensor log may hold")
    if _deeper_than(meta, MAX_JSON_DEPTH):
        raise InputError(f"{where}: meta: JSON nested deeper than {MAX_JSON_DEPTH} levels")
    meta_text = json.dumps(meta, sort_keys=True)
    if len(meta_text) > MAX_META_CHARS:
        raise InputError(f"{where}: meta: {len(meta_text):,} characters, more than the "
                         f"{MAX_META_CHARS:,} a log's meta may have")


def _deflates(data: bytes) -> bool:
    """Whether deflating `data` is worth it, judged on its first _PROBE bytes."""
    probe = data[:_PROBE]
    return len(zlib.compress(probe, _DEFLATE_LEVEL)) < (1.0 - _MIN_GAIN) * len(probe)


def parse_json(text: str, where: str, max_depth: int = MAX_JSON_DEPTH):
    """The value of JSON `text`; InputError naming `where` when it is not valid JSON or is
    nested deeper than `max_depth` (lists and mappings in one another)."""
    try:
        value = json.loads(text)
    except RecursionError:   # json's own recursion, at a depth near Python's limit
        raise InputError(f"{where}: JSON nested deeper than {max_depth} levels") from None
    except ValueError as err:   # JSONDecodeError, or an integer of more than 4300 digits
        raise InputError(f"{where}: not valid JSON: {' '.join(str(err).split())[:200]}") from None
    if _deeper_than(value, max_depth):
        raise InputError(f"{where}: JSON nested deeper than {max_depth} levels")
    return value


def _deeper_than(value, limit: int) -> bool:
    """Whether lists and dicts nest more than `limit` levels in `value` (iterative: a deep
    value must not exhaust the recursion this check is there to protect)."""
    stack = [(value, 1)] if isinstance(value, (dict, list)) else []
    while stack:
        v, depth = stack.pop()
        if depth > limit:
            return True
        children = v.values() if isinstance(v, dict) else v
        stack.extend((c, depth + 1) for c in children if isinstance(c, (dict, list)))
    return False


def _member_header(zf: zipfile.ZipFile, info: zipfile.ZipInfo, where: str):
    """(shape, dtype) from the .npy header of a zip member, read without its data;
    InputError naming the member when its declared uncompressed size (ZipInfo.file_size) is
    not what that array needs, or it holds Python objects."""
    with zf.open(info) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
        else:
            raise InputError(f"{where}: {info.filename}: .npy format version "
                             f"{version[0]}.{version[1]} is not read (1.0 and 2.0 are)")
        header = fh.tell()
    if dtype.hasobject:
        raise InputError(f"{where}: {info.filename}: holds Python objects (a pickle), not numbers")
    need = header + math.prod(shape) * dtype.itemsize
    if info.file_size != need:   # more: a bomb behind a small header; less: cut short
        raise InputError(f"{where}: {info.filename}: declares {info.file_size:,} bytes "
                         f"uncompressed, its {shape} {dtype} array needs {need:,}")
    return shape, dtype


def _checked_shapes(zf: zipfile.ZipFile, where: str) -> dict[str, tuple]:
    """name -> shape of the log's arrays, from their headers: InputError before any array is
    read when a member is missing, is not made of numbers, the arrays disagree in shape
    (sim.log's rules) or would take more than MAX_LOG_BYTES as float64."""
    present = set(zf.namelist())
    missing = [n for n in _ARRAYS if f"{n}.npy" not in present]
    if missing:
        raise InputError(f"{where}: missing arrays: {', '.join(missing)}")
    shapes, total = {}, 0
    for name in _ARRAYS:
        info = zf.getinfo(f"{name}.npy")
        if info.file_size > _BOMB_MIN_BYTES and info.file_size > _BOMB_RATIO * info.compress_size:
            raise InputError(f"{where}: {info.filename}: {info.compress_size:,} compressed bytes "
                             f"inflate to {info.file_size:,}, more than {_BOMB_RATIO} times: a zip "
                             "bomb, not sensor data")
        shape, dtype = _member_header(zf, info, where)
        if dtype.kind not in "biuf":
            raise InputError(f"{where}: {info.filename}: expected numbers, got dtype {dtype}")
        total += math.prod(shape) * 8   # read as float64
        if total > MAX_LOG_BYTES:
            raise InputError(f"{where}: {info.filename}: its {shape} array brings the log to "
                             f"{total:,} bytes, more than the {MAX_LOG_BYTES:,} a sensor log "
                             "may hold")
        shapes[name] = shape
    # zero-stride views: the shape rules checked without allocating the arrays
    problem = _shape_problem({n: np.broadcast_to(np.float64(0.0), s) for n, s in shapes.items()})
    if problem:
        raise InputError(f"{where}: {problem}")
    return shapes


def _read_meta(zf: zipfile.ZipFile, where: str) -> dict:
    """The log's meta mapping from its `meta.npy` (a JSON string), size and depth checked."""
    if "meta.npy" not in zf.namelist():
        raise InputError(f"{where}: not a sensor log: no 'meta' entry")
    info = zf.getinfo("meta.npy")
    shape, dtype = _member_header(zf, info, where)
    if dtype.kind not in "US" or math.prod(shape) != 1:
        raise InputError(f"{where}: meta: expected one JSON string, got a {shape} {dtype} array")
    chars = dtype.itemsize // (4 if dtype.kind == "U" else 1)
    if chars > MAX_META_CHARS:
        raise InputError(f"{where}: meta: {chars:,} characters, more than the "
                         f"{MAX_META_CHARS:,} a log's meta may have")
    with zf.open(info) as fh:
        text = np.lib.format.read_array(fh, allow_pickle=False).reshape(-1)[0]
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    meta = parse_json(str(text), f"{where}: meta")
    if not isinstance(meta, dict):
        raise InputError(f"{where}: meta: expected a mapping, got {type(meta).__name__}")
    return meta


def read_log(path: str | Path) -> SensorLog:
    """Read and check a sensor log; a bad file raises InputError naming it and the problem.

    Sizes and shapes are checked from the members' headers before any array is read (module
    docstring); values are checked by sim.logcheck.
    """
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: file not found")
    try:
        with zipfile.ZipFile(p) as zf:
            meta = _read_meta(zf, str(p))
            version = meta.get("format_version")
            if not isinstance(version, int) or isinstance(version, bool) or version < 1:
                raise InputError(f"{p}: meta.format_version: expected an integer >= 1, "
                                 f"got {short(version)}")
            if version > FORMAT_VERSION:
                raise InputError(f"{p}: meta.format_version: {version} is newer than this "
                                 f"reader (reads up to {FORMAT_VERSION}); upgrade the package")
            _checked_shapes(zf, str(p))
            arrays = {}
            for name in _ARRAYS:
                with zf.open(f"{name}.npy") as fh:
                    arrays[name] = np.asarray(np.lib.format.read_array(fh, allow_pickle=False),
                                              dtype=np.float64)
    except InputError:
        raise
    except Exception as err:   # any damage zip or npy parsing can meet
        reason = " ".join(str(err).split()) or type(err).__name__
        raise InputError(f"{p}: not a readable sensor log (.npz): {reason}") from None
    problem = _shape_problem(arrays) or log_problem(arrays, meta)
    if problem:
        raise InputError(f"{p}: {problem}")
    return SensorLog(**arrays, meta=meta)


def value_problem(log: SensorLog) -> str | None:
    """None if the log's values follow sim.logcheck's rules, else the first problem."""
    return log_problem({name: getattr(log, name) for name in _ARRAYS}, log.meta)


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
