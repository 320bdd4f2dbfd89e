"""Readers for real robot logs: CARMEN (.log/.clf, gzip or plain) and GMapping .gfs -> SensorLog.

CARMEN messages read (every message ends with `ipc_timestamp hostname logger_timestamp`;
the ipc timestamp is used, as the Freiburg relations files do):
  FLASER n r_1..r_n  x y theta  odom_x odom_y odom_theta  ipc host logger
      (x y theta: laser pose, odom_*: robot odometry pose; no beam angles in the line)
  ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode
      n r_1..r_n  m rem_1..rem_m  laser_x laser_y laser_theta  robot_x robot_y robot_theta
      tv rv forward_safety side_safety turn_axis  ipc host logger
  RAWLASER1 type start_angle fov resolution max_range accuracy remission_mode
      n r_1..r_n  m rem_1..rem_m  ipc host logger          (no pose)
  ODOM x y theta tv rv accel  ipc host logger
  PARAM name value ...   (robot_frontlaser_offset is recorded in meta)
GMapping .gfs messages read:
  LASER_READING n r_1..r_n x y theta timestamp   ODOM x y theta timestamp
  PARAM name value   (maxrange)
Other messages (NEFF, SYNC, RLASER, ODO_UPDATE, SM_UPDATE, RESAMPLE, FRAME, comments) are
counted in meta.messages and otherwise skipped.

Conventions (sim.logs.sensorlog): beam angles in the lidar frame, from the message when it has
them, else the documented defaults (180 or 181 beams: 1 degree steps, 360 or 361 beams: 0.5
degree steps, other counts: 180 degrees / n; all starting at -90 degrees). A reading at the
sensor's maximum is a no return (inf): the Radish logs mark it with one frequent value at the
top of the file's readings (81.83, 81.91, 50.0, 51.15, 32.767 m, with neighbours a few cm
below), so readings within `NO_RETURN_MARGIN` below that marker or above it, or at or above the
range the message or a PARAM declares, become inf.
Odometry: the robot pose fields of FLASER / ROBOTLASER1 (one exact pose per scan) when the
scans carry them, else the ODOM lines. The .gfs LASER_READING pose is not used: it equals
the pose of the next ODOM line, about 0.2 s later (README of the Radish data). GMapping's
writer (GridSlamProcessor::processScan) stamps each ODOM line with the current reading's time
but the previous reading's odometry, and the LASER_READING with the reading's own; pairing the
poses one line earlier was measured on CSAIL and not adopted: it agrees worse with GMapping's
corrected poses (median per-scan rotation error 3.5 against 3.0 degrees) and moves pf's and
graph's relations errors by +0.001 and +0.03 m.
A log whose odometry fields hold SLAM-corrected poses is marked
meta.odometry_kind = "corrected" (detected: GMapping's NEFF lines, or ROBOTLASER1 lines whose
velocities are all zero and whose laser pose equals the robot pose); no ground truth is set.
meta.start_pose is None: a SLAM on a real log starts at the origin. meta.noise.lidar is the
SICK LMS 2xx's range noise (SICK_LMS_NOISE; an assumption the file cannot confirm).
"""
from __future__ import annotations

import gzip
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from worlds.yamlio import InputError
from sim.logs.sensorlog import SensorLog, value_problem

__all__ = ["import_log", "detect_format", "default_angles", "FORMATS", "NO_RETURN_MARGIN"]

FORMATS = ("carmen", "gfs")
NO_RETURN_MARGIN = 0.1  # m: the Radish no-return markers spread over about 0.05 m below the top
MARKER_WINDOW = 0.5     # m: the marker is searched this close to the file's largest reading
# A few out-of-order stamps are glitches (intel: one scan 1.1 s early); many mean the times were
# printed with too few digits (%g), and the log's timing is lost.
MAX_DROPPED_FRACTION = 0.01

# CARMEN logs come from the SICK LMS 2xx that CARMEN's laser module drives (the Radish logs:
# Intel, Freiburg 079, MIT CSAIL). The LMS 200's technical description: systematic error
# +-15 mm, statistical error 5 mm (1 sigma), at the ranges indoor logs see; the +-15 mm read
# as a 2-sigma bound as the simulator's datasheets: sigma = sqrt(5^2 + 7.5^2) = 9 mm at any range.
SICK_LMS_NOISE = {"stddev": 0.005, "accuracy_sigmas": 2.0, "bands": [[80.0, 0.015, 0.0]]}

_CARMEN_SCANS = ("FLASER", "ROBOTLASER1", "RAWLASER1")
_GFS_ONLY = ("LASER_READING", "ODO_UPDATE", "SM_UPDATE", "RESAMPLE", "FRAME")


def default_angles(n: int) -> np.ndarray:
    """(n,) beam angles (rad) of a scan line that gives none: 180 degrees from -90 degrees.

    180/181 beams: 1 degree steps; 360/361 beams: 0.5 degree steps; otherwise 180 / n degrees.
    """
    if n in (180, 181):
        step = 1.0
    elif n in (360, 361):
        step = 0.5
    else:
        step = 180.0 / n
    return np.deg2rad(-90.0 + step * np.arange(n))


def _open_lines(path: Path):
    """The file's text lines; gzip detected from its magic bytes, not its name."""
    try:
        with open(path, "rb") as fh:
            magic = fh.read(2)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except OSError as err:
        raise InputError(f"{path}: cannot read: {err.strerror}") from None
    try:
        if magic == b"\x1f\x8b":
            with gzip.open(path, "rt", encoding="latin-1") as fh:
                return fh.read().splitlines()
        with open(path, "rt", encoding="latin-1") as fh:
            return fh.read().splitlines()
    except (OSError, EOFError) as err:
        raise InputError(f"{path}: cannot read: {err}") from None


def detect_format(lines: list[str]) -> str | None:
    """'gfs' if GMapping-only messages appear, 'carmen' if CARMEN scan/odometry lines do, else None."""
    carmen = False
    for line in lines:
        head = line.split(None, 1)[0] if line.strip() else ""
        if head in _GFS_ONLY:
            return "gfs"
        if head in _CARMEN_SCANS:
            carmen = True
        elif head == "ODOM":
            carmen = carmen or len(line.split()) == 10
    return "carmen" if carmen else None


def import_log(path: str | os.PathLike, fmt: str | None = None) -> SensorLog:
    """Read a CARMEN or GMapping .gfs log into a SensorLog.

    fmt: "carmen", "gfs" or None (detected from the content). Malformed lines raise InputError
    naming the file and line number; a file without scans, scans whose beam count or angles
    change, or scan timestamps that do not increase (logs printed with %g timestamps) too.
    """
    p = Path(path)
    lines = _open_lines(p)
    if fmt is None:
        fmt = detect_format(lines)
        if fmt is None:
            raise InputError(f"{p}: no laser scan or odometry message found "
                             f"(not a CARMEN or GMapping .gfs log?)")
    if fmt not in FORMATS:
        raise InputError(f"{p}: unknown log format '{fmt}' (known: {', '.join(FORMATS)})")
    acc = _Accumulator(p, fmt)
    parse = _parse_gfs_line if fmt == "gfs" else _parse_carmen_line
    for lineno, line in enumerate(lines, start=1):
        tokens = line.split()
        if not tokens or tokens[0].startswith("#"):
            continue
        acc.count(tokens[0])
        parse(acc, tokens, lineno)
    log = acc.build()
    problem = value_problem(log)
    if problem:
        raise InputError(f"{p}: {problem}")
    return log


# --- parsing -------------------------------------------------------------------------------

@dataclass
class _Accumulator:
    """Collects parsed messages and builds the SensorLog; keeps line numbers for errors."""

    path: Path
    fmt: str
    scan_t: list = field(default_factory=list)
    scan_ranges: list = field(default_factory=list)
    scan_lines: list = field(default_factory=list)
    angles: np.ndarray | None = None
    angles_from: str = ""
    declared_max: float = np.inf
    laser_pose: list = field(default_factory=list)   # per scan, or empty
    robot_pose: list = field(default_factory=list)   # per scan, or empty
    robot_twist_zero: bool = True
    odom_t: list = field(default_factory=list)
    odom_pose: list = field(default_factory=list)
    odom_twist: list = field(default_factory=list)
    odom_lines: list = field(default_factory=list)
    params: dict = field(default_factory=dict)
    messages: dict = field(default_factory=dict)

    def error(self, lineno: int, msg: str) -> InputError:
        return InputError(f"{self.path}: line {lineno}: {msg}")

    def count(self, name: str) -> None:
        self.messages[name] = self.messages.get(name, 0) + 1

    def add_scan(self, lineno: int, t: float, ranges: np.ndarray, angles: np.ndarray,
                 angles_from: str, max_range: float = np.inf) -> None:
        if self.angles is None:
            self.angles, self.angles_from = angles, angles_from
        elif len(angles) != len(self.angles):
            raise self.error(lineno, f"scan has {len(angles)} beams, earlier scans have "
                                     f"{len(self.angles)} (one log holds one laser)")
        elif not np.allclose(angles, self.angles, atol=1e-6):
            raise self.error(lineno, "beam angles differ from those of the earlier scans")
        self.declared_max = min(self.declared_max, max_range)
        self.scan_t.append(t)
        self.scan_ranges.append(ranges)
        self.scan_lines.append(lineno)

    def build(self) -> SensorLog:
        if not self.scan_t:
            raise InputError(f"{self.path}: no laser scans in the file "
                             f"(messages: {_fmt_counts(self.messages) or 'none'})")
        keep = _increasing_subsequence(np.array(self.scan_t))
        dropped = [self.scan_lines[i] for i in np.flatnonzero(~keep)]
        if len(dropped) > MAX_DROPPED_FRACTION * len(keep):
            raise InputError(f"{self.path}: the scan timestamps are unusable: {len(dropped)} of "
                             f"{len(keep)} scans are out of time order (first at line {dropped[0]}); "
                             "logs printed with %g timestamps lose them")
        scan_t = np.array(self.scan_t)[keep]
        ranges = np.array(self.scan_ranges)[keep]
        marker = _no_return_marker(ranges)
        threshold = min(self.declared_max, marker - NO_RETURN_MARGIN)
        ranges = np.where((ranges >= threshold) | (ranges <= 0.0), np.inf, ranges)
        range_max = float(min(self.declared_max, marker))

        offset = np.zeros(3)
        if self.robot_pose:
            robot = np.array(self.robot_pose)[keep]
            laser = np.array(self.laser_pose)[keep]
            offset = _median_offset(robot, laser)
            odom_t, odom_pose = scan_t, robot
            odom_twist = _finite_difference_twist(odom_t, odom_pose)
            source = "scan robot poses"
        else:
            odom_t, odom_pose, odom_twist = self._odom_lines()
            source = "ODOM lines"
        # GMapping writes NEFF lines into the corrected CARMEN logs it outputs; a .gfs keeps
        # the raw odometry in its ODOM lines
        corrected = self.fmt == "carmen" and ("NEFF" in self.messages
                     or (self.messages.get("ROBOTLASER1", 0) > 0 and self.robot_twist_zero
                         and bool(np.all(np.abs(offset) < 1e-9))
                         and np.allclose(self.laser_pose, self.robot_pose, atol=1e-9)))
        meta = {
            # "sim.importers": the value every imported log carries (another would change
            # the bytes of every re-import)
            "source": str(self.path), "format": self.fmt, "importer": "sim.importers",
            "messages": dict(sorted(self.messages.items())),
            "lidar": {"range_min": 0.0, "range_max": range_max, "offset": offset.tolist(),
                      "time_increment": 0.0, "no_return_at_or_above": threshold,
                      "angles_from": self.angles_from, "beams": int(len(self.angles))},
            "noise": {"name": "sick-lms (assumed)", "lidar": dict(SICK_LMS_NOISE)},
            "start_pose": None,
            "odometry_kind": "corrected" if corrected else "raw",
            "odometry_source": source,
            "time_base": "ipc timestamp" if self.fmt == "carmen" else "gfs timestamp",
            "params": self.params,
            "dropped_scan_lines": dropped,
        }
        return SensorLog(scan_t=scan_t, scan_ranges=ranges,
                         scan_angles=self.angles, odom_t=odom_t, odom_pose=odom_pose,
                         odom_twist=odom_twist, meta=meta)

    def _odom_lines(self):
        """ODOM samples in time order; samples out of time order (a few ODOM lines of the
        fr079 log carry 0 or negative times) are dropped."""
        if not self.odom_t:
            return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 2))
        t = np.array(self.odom_t)
        keep = _increasing_subsequence(t)
        self.params["odom_lines_dropped"] = int((~keep).sum())
        t, pose = t[keep], np.array(self.odom_pose)[keep]
        twist = np.array(self.odom_twist)[keep]
        if not np.any(twist):  # the logs here record tv = rv = 0: derive them from the poses
            twist = _finite_difference_twist(t, pose)
        return t, pose, twist


def _fmt_counts(counts: dict) -> str:
    return ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))


def _floats(acc: _Accumulator, tokens: list[str], lineno: int) -> np.ndarray:
    try:
        vals = np.array([float(x) for x in tokens])
    except ValueError:
        bad = next(x for x in tokens if not _is_float(x))
        raise acc.error(lineno, f"{tokens and tokens[0]}: not a number: {bad!r}") from None
    if not np.all(np.isfinite(vals)):
        raise acc.error(lineno, "non-finite number")
    return vals


def _is_float(x: str) -> bool:
    try:
        float(x)
        return True
    except ValueError:
        return False


def _count_field(acc: _Accumulator, tok: str, lineno: int, name: str) -> int:
    try:
        n = int(tok)
    except ValueError:
        raise acc.error(lineno, f"{name}: expected an integer count, got {tok!r}") from None
    if n < 0:
        raise acc.error(lineno, f"{name}: negative count {n}")
    return n


def _reading_count(acc: _Accumulator, tokens: list[str], lineno: int) -> int:
    """The number of readings a FLASER or LASER_READING line declares after its name."""
    if len(tokens) < 2:
        raise acc.error(lineno, f"{tokens[0]}: missing the number of readings")
    return _count_field(acc, tokens[1], lineno, f"{tokens[0]} num_readings")


def _need(acc: _Accumulator, tokens: list[str], lineno: int, want: int, layout: str) -> None:
    if len(tokens) != want:
        raise acc.error(lineno, f"{tokens[0]}: expected {want} fields ({layout}), got {len(tokens)}")


def _parse_carmen_line(acc: _Accumulator, tokens: list[str], lineno: int) -> None:
    kind = tokens[0]
    if kind == "FLASER":
        n = _reading_count(acc, tokens, lineno)
        _need(acc, tokens, lineno, 2 + n + 9,
              f"FLASER {n} readings, laser pose, odometry pose, ipc_timestamp host logger_timestamp")
        vals = _floats(acc, tokens[2:2 + n + 7], lineno)
        ranges, laser, robot, t = vals[:n], vals[n:n + 3], vals[n + 3:n + 6], vals[n + 6]
        acc.add_scan(lineno, float(t), ranges, default_angles(n), "default (FLASER has none)")
        acc.laser_pose.append(laser)
        acc.robot_pose.append(robot)
    elif kind in ("ROBOTLASER1", "RAWLASER1"):
        _parse_laser1(acc, tokens, lineno, with_pose=(kind == "ROBOTLASER1"))
    elif kind == "ODOM":
        _need(acc, tokens, lineno, 10, "ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp")
        vals = _floats(acc, tokens[1:8], lineno)
        acc.odom_pose.append(vals[0:3])
        acc.odom_twist.append(vals[3:5])
        acc.odom_t.append(float(vals[6]))
        acc.odom_lines.append(lineno)
    elif kind == "PARAM" and len(tokens) >= 3:
        if tokens[1] in ("robot_frontlaser_offset", "robot_front_laser_max",
                         "laser_front_laser_resolution", "laser_front_laser_fov"):
            acc.params[tokens[1]] = tokens[2]


def _parse_laser1(acc: _Accumulator, tokens: list[str], lineno: int, with_pose: bool) -> None:
    kind = tokens[0]
    if len(tokens) < 9:
        raise acc.error(lineno, f"{kind}: too few fields ({len(tokens)})")
    head = _floats(acc, tokens[2:7], lineno)
    start, fov, res, max_range = head[0], head[1], head[2], head[3]
    n = _count_field(acc, tokens[8], lineno, f"{kind} num_readings")
    if len(tokens) < 9 + n + 1:
        raise acc.error(lineno, f"{kind}: line ends inside the {n} readings")
    m = _count_field(acc, tokens[9 + n], lineno, f"{kind} num_remissions")
    tail = 3 + (6 + 5 if with_pose else 0)
    _need(acc, tokens, lineno, 10 + n + m + tail,
          f"{kind} header, {n} readings, {m} remissions, "
          + ("laser and robot pose, tv rv safety fields, " if with_pose else "")
          + "ipc_timestamp host logger_timestamp")
    ranges = _floats(acc, tokens[9:9 + n], lineno)
    rest = tokens[10 + n + m:]
    if res <= 0:
        raise acc.error(lineno, f"{kind}: angular resolution {res} must be positive")
    angles = start + res * np.arange(n)
    if with_pose:
        vals = _floats(acc, rest[0:12], lineno)
        acc.laser_pose.append(vals[0:3])
        acc.robot_pose.append(vals[3:6])
        acc.robot_twist_zero = acc.robot_twist_zero and vals[6] == 0.0 and vals[7] == 0.0
        t = vals[11]
    else:
        t = _floats(acc, rest[0:1], lineno)[0]
    acc.add_scan(lineno, float(t), ranges, angles, "message", max_range=float(max_range))


def _parse_gfs_line(acc: _Accumulator, tokens: list[str], lineno: int) -> None:
    kind = tokens[0]
    if kind == "LASER_READING":
        n = _reading_count(acc, tokens, lineno)
        _need(acc, tokens, lineno, 2 + n + 4, f"LASER_READING {n} readings, x y theta, timestamp")
        vals = _floats(acc, tokens[2:], lineno)
        acc.add_scan(lineno, float(vals[n + 3]), vals[:n], default_angles(n),
                     "default (LASER_READING has none)")
    elif kind == "ODOM":
        _need(acc, tokens, lineno, 5, "ODOM x y theta timestamp")
        vals = _floats(acc, tokens[1:], lineno)
        acc.odom_pose.append(vals[0:3])
        acc.odom_twist.append(np.zeros(2))
        acc.odom_t.append(float(vals[3]))
        acc.odom_lines.append(lineno)
    elif kind == "PARAM" and len(tokens) >= 3:
        if tokens[1] == "maxrange":
            try:
                acc.declared_max = min(acc.declared_max, float(tokens[2]))
            except ValueError:
                raise acc.error(lineno, f"PARAM maxrange: not a number: {tokens[2]!r}") from None
        acc.params[tokens[1]] = tokens[2]


# --- helpers ---------------------------------------------------------------------------------

def _no_return_marker(ranges: np.ndarray) -> float:
    """The value a log writes for "no return": the most frequent reading within
    MARKER_WINDOW of the largest one (a few stray readings can lie above the marker: acapulco
    has 51.25 and 51.2 above 9264 readings of 51.15); the largest reading if none repeats."""
    if ranges.size == 0:
        return 0.0
    top = ranges[ranges >= ranges.max() - MARKER_WINDOW]
    values, counts = np.unique(top, return_counts=True)
    if counts.max() < 2:
        return float(ranges.max())
    return float(values[np.argmax(counts)])


def _increasing_subsequence(t: np.ndarray) -> np.ndarray:
    """(N,) bool mask of a longest strictly increasing subsequence of t (patience sorting):
    the samples kept when a few timestamps are out of order."""
    n = len(t)
    tails: list[int] = []          # index of the smallest tail of an increasing run of each length
    prev = np.full(n, -1)
    for i in range(n):
        lo, hi = 0, len(tails)
        while lo < hi:
            mid = (lo + hi) // 2
            if t[tails[mid]] < t[i]:
                lo = mid + 1
            else:
                hi = mid
        prev[i] = tails[lo - 1] if lo > 0 else -1
        if lo == len(tails):
            tails.append(i)
        else:
            tails[lo] = i
    keep = np.zeros(n, dtype=bool)
    i = tails[-1] if tails else -1
    while i >= 0:
        keep[i] = True
        i = prev[i]
    return keep


def _median_offset(robot: np.ndarray, laser: np.ndarray) -> np.ndarray:
    """(3,) laser pose in the robot frame: the median over scans of robot^-1 * laser.

    In raw CARMEN logs FLASER's first pose is the laser pose (0.04 m behind the odometry pose in
    fr079, as PARAM robot_frontlaser_offset says); in corrected logs both triples are equal.
    """
    c, s = np.cos(robot[:, 2]), np.sin(robot[:, 2])
    dx, dy = laser[:, 0] - robot[:, 0], laser[:, 1] - robot[:, 1]
    local = np.stack([c * dx + s * dy, -s * dx + c * dy,
                      np.angle(np.exp(1j * (laser[:, 2] - robot[:, 2])))], axis=1)
    off = np.median(local, axis=0)
    off[np.abs(off) < 1e-9] = 0.0
    return off


def _finite_difference_twist(t: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(M, 2) forward speed (m/s) and turn rate (rad/s) from consecutive poses (0 for the last)."""
    twist = np.zeros((len(t), 2))
    if len(t) < 2:
        return twist
    dt = np.diff(t)
    c, s = np.cos(pose[:-1, 2]), np.sin(pose[:-1, 2])
    dx, dy = np.diff(pose[:, 0]), np.diff(pose[:, 1])
    dyaw = np.angle(np.exp(1j * np.diff(pose[:, 2])))
    twist[:-1, 0] = (c * dx + s * dy) / dt
    twist[:-1, 1] = dyaw / dt
    twist[-1] = twist[-2]
    return twist
