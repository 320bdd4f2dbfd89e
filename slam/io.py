"""SLAM result files (docs/formats.md): DIR/map.yaml + map.pgm (ROS map_server pair, written by
worlds.mapio.write_map), DIR/trajectory.tum (TUM: t x y z qx qy qz qw, evo-readable),
DIR/stats.json (wall time, scans processed, real-time factor, ...), DIR/config.yaml (the
effective config). read_result reads the directory back.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from worlds.mapio import read_map, write_map
from worlds.yamlio import InputError, atomic_write_text, dump_yaml, load_yaml
from slam.base import SlamResult

__all__ = ["write_result", "read_result", "write_tum", "read_tum"]

RESULT_FILES = ("map.yaml", "map.pgm", "trajectory.tum", "stats.json", "config.yaml")


def write_tum(path: str | os.PathLike, t: np.ndarray, poses: np.ndarray) -> None:
    """(N,) times s and (N, 3) poses x, y, yaw -> TUM text (z = 0, rotation about z)."""
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    half = poses[:, 2] / 2.0
    lines = [f"{ti:.9f} {x:.9g} {y:.9g} 0 0 0 {np.sin(h):.12g} {np.cos(h):.12g}"
             for ti, (x, y, _), h in zip(t, poses, half)]
    atomic_write_text(path, "".join(line + "\n" for line in lines))


def read_tum(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """TUM text -> (N,) times and (N, 3) poses x, y, yaw (yaw from the quaternion about z)."""
    p = Path(path)
    try:
        a = np.loadtxt(p, comments="#", ndmin=2)
    except (OSError, ValueError) as err:
        raise InputError(f"{p}: not a readable TUM trajectory: {err}") from None
    if a.size == 0:
        return np.zeros(0), np.zeros((0, 3))
    if a.shape[1] != 8:
        raise InputError(f"{p}: expected 8 columns (t x y z qx qy qz qw), got {a.shape[1]}")
    qx, qy, qz, qw = a[:, 4], a[:, 5], a[:, 6], a[:, 7]
    yaw = np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    return a[:, 0].copy(), np.stack([a[:, 1], a[:, 2], yaw], axis=1)


def _jsonable(v):
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, float) and not np.isfinite(v):
        return None if np.isnan(v) else (1e308 if v > 0 else -1e308)
    return v


def write_result(result: SlamResult, out_dir: str | os.PathLike) -> Path:
    """Write the files of a SLAM result into `out_dir` (created if needed); returns the directory."""
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{out}: cannot create output directory: {err.strerror}") from None
    write_map(result.grid, out / "map.yaml")
    write_tum(out / "trajectory.tum", result.times, result.poses)
    atomic_write_text(out / "stats.json", json.dumps(_jsonable(result.stats), indent=2, sort_keys=True) + "\n")
    atomic_write_text(out / "config.yaml", dump_yaml(result.config))
    return out


def read_result(out_dir: str | os.PathLike) -> SlamResult:
    """Read a directory written by write_result (the map comes back trinary: 1.0 / 0.0 / NaN)."""
    out = Path(out_dir)
    missing = [f for f in RESULT_FILES if not (out / f).exists()]
    if missing:
        raise InputError(f"{out}: not a SLAM result directory (missing {', '.join(missing)})")
    grid = read_map(out / "map.yaml")
    t, poses = read_tum(out / "trajectory.tum")
    try:
        stats = json.loads((out / "stats.json").read_text())
    except json.JSONDecodeError as err:
        raise InputError(f"{out / 'stats.json'}: not valid JSON: {err}") from None
    config = load_yaml(out / "config.yaml") or {}
    return SlamResult(grid, t, poses, stats, config)
