"""TUM trajectory text files (`t x y z qx qy qz qw`, one pose a line), as read by evo: the one
reader and writer of them (slam writes its trajectory.tum with it, metrics and bench read
estimated and true trajectories with it).

A 2D pose (x, y, yaw) is stored with z = 0 and the quaternion of a rotation about z;
reading takes the yaw out of any unit quaternion (roll and pitch are ignored).
Every value must be finite and within a sane bound (MAX_TIME_S, MAX_COORD_M, MAX_QUATERNION):
1e308 overflows the squares of any alignment and scores garbage as a number.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from worlds.limits import MAX_COORDINATE
from worlds.yamlio import InputError, atomic_write_text

__all__ = ["read_tum", "write_tum", "yaw_from_quaternion", "read_number_rows", "MAX_COORD_M",
           "MAX_TIME_S", "MAX_QUATERNION"]

# positions: the bound every reader of positions shares (worlds.limits)
MAX_COORD_M = MAX_COORDINATE
# seconds: Unix time until the year 2286; a file in nanoseconds (1.7e18) is refused instead
# of being read as a trajectory 50 billion years long
MAX_TIME_S = 1e10
# a unit quaternion's parts lie in [-1, 1]; leeway for unnormalised writers, none for garbage
MAX_QUATERNION = 1e6
_TUM_LAYOUT = "t x y z qx qy qz qw"
_TUM_LIMITS = {"t": MAX_TIME_S, "x": MAX_COORD_M, "y": MAX_COORD_M, "z": MAX_COORD_M,
               "qx": MAX_QUATERNION, "qy": MAX_QUATERNION, "qz": MAX_QUATERNION,
               "qw": MAX_QUATERNION}


def yaw_from_quaternion(qx, qy, qz, qw):
    """Yaw (rad, rotation about z) of quaternion(s) (x, y, z, w); arrays broadcast."""
    qx, qy, qz, qw = (np.asarray(q, dtype=np.float64) for q in (qx, qy, qz, qw))
    return np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def read_number_rows(path: str | os.PathLike, layout: str, empty: str,
                     limits: dict[str, float] | None = None
                     ) -> tuple[Path, np.ndarray, np.ndarray]:
    """Rows of a whitespace-separated text table with one field per name in `layout`.

    Blank lines and '#' lines are skipped; a missing file, a line with another number of
    fields, a non-number, a non-finite value or one beyond its bound in `limits` (field name
    -> largest magnitude) raise InputError naming the file, line and field, and so does a file
    without rows (message `empty`). Returns (path, (N, fields) float64 array, (N,) line
    numbers of the rows, for messages about a row).
    """
    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise InputError(f"{p}: file not found") from None
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{p}: cannot read as text: {err}") from None
    names = layout.split()
    n = len(names)
    bounds = [(limits or {}).get(name, np.inf) for name in names]
    rows, linenos = [], []
    for lineno, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.replace(",", " ").split()
        if len(parts) != n:
            raise InputError(f"{p}: line {lineno}: expected {n} numbers '{layout}', "
                             f"got {len(parts)} fields")
        try:
            vals = [float(v) for v in parts]
        except ValueError:
            raise InputError(f"{p}: line {lineno}: not a number in {s[:60]!r}") from None
        for name, v, bound in zip(names, vals, bounds):
            if not np.isfinite(v):
                raise InputError(f"{p}: line {lineno}: non-finite {name}: {v}")
            if abs(v) > bound:
                raise InputError(f"{p}: line {lineno}: {name}: {v:g} is beyond +-{bound:g}")
        rows.append(vals)
        linenos.append(lineno)
    if not rows:
        raise InputError(f"{p}: {empty}")
    return p, np.array(rows), np.array(linenos)


def read_tum(path: str | os.PathLike, bounds: tuple[float, float, float, float] | None = None,
             margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Read a TUM trajectory file.

    Returns (t, poses): t (N,) seconds, poses (N, 3) x, y (m), yaw (rad), sorted by time.
    Blank lines and lines starting with '#' are skipped. A missing file, a line without
    8 numbers, a value that is not finite or beyond its bound (module docstring), a zero
    quaternion, repeated times or an empty file raise InputError naming the file and line;
    so does, when the world's `bounds` (xmin, ymin, xmax, ymax) m are given, a position
    more than `margin` m outside them.
    """
    p, a, linenos = read_number_rows(path, _TUM_LAYOUT, "no poses (not a TUM trajectory file?)",
                                     _TUM_LIMITS)
    if bounds is not None:
        _check_within(p, a[:, 1:3], linenos, bounds, margin)
    zero = np.flatnonzero(np.hypot(np.hypot(a[:, 4], a[:, 5]), np.hypot(a[:, 6], a[:, 7])) < 1e-9)
    if len(zero):
        raise InputError(f"{p}: line {linenos[zero[0]]}: zero quaternion")
    order = np.argsort(a[:, 0], kind="stable")
    a = a[order]
    if np.any(np.diff(a[:, 0]) <= 0):
        raise InputError(f"{p}: repeated timestamps")
    yaw = yaw_from_quaternion(a[:, 4], a[:, 5], a[:, 6], a[:, 7])
    return a[:, 0].copy(), np.stack([a[:, 1], a[:, 2], yaw], axis=1)


def _check_within(p: Path, xy: np.ndarray, linenos: np.ndarray,
                  bounds: tuple[float, float, float, float], margin: float) -> None:
    """InputError naming the file, line and field of the first of the (N, 2) positions more
    than `margin` m outside the world's `bounds` (xmin, ymin, xmax, ymax) m."""
    low = np.array(bounds[:2]) - margin
    high = np.array(bounds[2:]) + margin
    out = (xy < low) | (xy > high)
    if out.any():
        i, axis = np.argwhere(out)[0]
        span = f"{bounds[axis]:g}..{bounds[axis + 2]:g} m"
        raise InputError(f"{p}: line {linenos[i]}: {'xy'[axis]}: {xy[i, axis]:g} m is more than "
                         f"{margin:g} m outside the world ({span})")


def write_tum(path: str | os.PathLike, t: np.ndarray, poses: np.ndarray) -> None:
    """Write (N,) times (s) and (N, 3) poses x, y, yaw as a TUM file (z = 0, rotation about z)."""
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    if len(t) != len(poses):
        raise ValueError(f"write_tum: {len(t)} times but {len(poses)} poses")
    half = poses[:, 2] / 2.0
    lines = [f"{ti:.9f} {x:.9g} {y:.9g} 0 0 0 {np.sin(h):.12g} {np.cos(h):.12g}\n"
             for ti, (x, y, _), h in zip(t, poses, half)]
    atomic_write_text(path, "".join(lines))
