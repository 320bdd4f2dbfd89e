"""The values of a sensor log, checked (one function, used by every reader and writer of logs).

Rules (docs/formats.md):
- every time stream (scan_t, odom_t, imu_t, gt_t) finite and strictly increasing;
- scan_angles finite and strictly monotonic;
- scan_ranges non-negative, +inf for no return; NaN and negative values are rejected
  (importers turn their sources' invalid readings into +inf before writing);
- odom_pose and gt_pose finite, and no faster than MAX_SPEED_M_S between two samples (a jump
  is a broken log, not a robot); odom_twist and the IMU arrays finite;
- meta a mapping: format_version an integer >= 1, lidar (if present) a mapping whose range_min,
  range_max, time_increment are numbers >= 0 and whose offset is three finite numbers,
  start_pose (if given) three finite numbers, seed (if present) an integer.
"""
from __future__ import annotations

import math
from numbers import Real

import numpy as np

__all__ = ["MAX_SPEED_M_S", "log_problem", "meta_problem"]

MAX_SPEED_M_S = 10.0   # faster than any ground robot this benchmark is for, 40x a TurtleBot3's

_TIMES = ("scan_t", "odom_t", "imu_t", "gt_t")
_FINITE = ("odom_twist", "imu_gyro", "imu_accel", "imu_yaw")


def _first(mask: np.ndarray) -> str:
    """'[i]' or '[i, j]' of the first True of mask."""
    idx = np.unravel_index(int(np.argmax(mask)), mask.shape)
    return "[" + ", ".join(str(int(i)) for i in idx) + "]"


def _is_number(v) -> bool:
    return isinstance(v, Real) and not isinstance(v, bool)


def meta_problem(meta) -> str | None:
    """None if meta has the right types, else 'meta.FIELD: problem'."""
    if not isinstance(meta, dict):
        return f"meta: expected a mapping, got {type(meta).__name__}"
    version = meta.get("format_version", 1)   # absent: a log not yet written (an importer's)
    if not (isinstance(version, int) and not isinstance(version, bool) and version >= 1):
        return f"meta.format_version: expected an integer >= 1, got {version!r}"
    lidar = meta.get("lidar", {})
    if not isinstance(lidar, dict):
        return f"meta.lidar: expected a mapping, got {lidar!r}"
    for key in ("range_min", "range_max", "time_increment"):
        v = lidar.get(key, 0.0)
        if not _is_number(v) or math.isnan(v) or v < 0:
            return f"meta.lidar.{key}: expected a number >= 0, got {v!r}"
    start = meta.get("start_pose")   # None: unknown (a real log starts at the origin)
    for where, v in (("meta.lidar.offset", lidar.get("offset", [0, 0, 0])),
                     ("meta.start_pose", [0, 0, 0] if start is None else start)):
        if not (isinstance(v, (list, tuple)) and len(v) == 3
                and all(_is_number(x) and math.isfinite(x) for x in v)):
            return f"{where}: expected three finite numbers, got {v!r}"
    seed = meta.get("seed", 0)
    if not (isinstance(seed, int) and not isinstance(seed, bool)):
        return f"meta.seed: expected an integer, got {seed!r}"
    return None


def log_problem(arrays: dict[str, np.ndarray], meta) -> str | None:
    """None if the log's values follow the rules above, else 'ARRAY[index]: problem' (the
    first bad index) or 'meta.FIELD: problem'. arrays: the log's arrays by name, shapes checked."""
    problem = meta_problem(meta)
    if problem:
        return problem
    for name in _TIMES:
        t = arrays[name]
        if not np.isfinite(t).all():
            return f"{name}{_first(~np.isfinite(t))}: not a finite time"
        step = np.diff(t)
        if (step <= 0).any():
            i = int(np.argmax(step <= 0)) + 1
            return (f"{name}[{i}]: {float(t[i]):.9g} s is not after {name}[{i - 1}] = "
                    f"{float(t[i - 1]):.9g} s (times must increase)")
    a = arrays["scan_angles"]
    if not np.isfinite(a).all():
        return f"scan_angles{_first(~np.isfinite(a))}: not finite"
    da = np.diff(a)
    if len(da) and not ((da > 0).all() or (da < 0).all()):
        i = int(np.argmax(da * np.sign(da[0]) <= 0)) + 1
        return f"scan_angles[{i}]: the angles must be strictly increasing or decreasing"
    r = arrays["scan_ranges"]
    if np.isnan(r).any():
        return f"scan_ranges{_first(np.isnan(r))}: NaN (no return is +inf)"
    if (r < 0).any():
        return f"scan_ranges{_first(r < 0)}: negative range {float(r[r < 0][0]):g}"
    for name in _FINITE:
        v = arrays[name]
        if not np.isfinite(v).all():
            return f"{name}{_first(~np.isfinite(v))}: not finite"
    for pose, times in (("odom_pose", "odom_t"), ("gt_pose", "gt_t")):
        p, t = arrays[pose], arrays[times]
        if not np.isfinite(p).all():
            return f"{pose}{_first(~np.isfinite(p))}: not finite"
        if len(p) > 1:
            speed = np.hypot(*np.diff(p[:, :2], axis=0).T) / np.diff(t)
            if (speed > MAX_SPEED_M_S).any():
                i = int(np.argmax(speed > MAX_SPEED_M_S)) + 1
                jump = float(np.hypot(*(p[i, :2] - p[i - 1, :2])))
                return (f"{pose}[{i}]: jumps {jump:.3g} m in {t[i] - t[i - 1]:.3g} s (faster than "
                        f"{MAX_SPEED_M_S:g} m/s)")
    return None
