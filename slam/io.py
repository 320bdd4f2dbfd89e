"""SLAM result files (docs/formats.md): DIR/map.yaml + map.pgm (ROS map_server pair, written by
worlds.mapio.write_map), DIR/trajectory.tum (TUM: t x y z qx qy qz qw, evo-readable),
DIR/stats.json (wall time, scans processed, real-time factor, ...; strict JSON, worlds.jsonio),
DIR/config.yaml (the effective config). read_result reads the directory back.
"""
from __future__ import annotations

import os
from pathlib import Path

from worlds.jsonio import dumps, loads
from worlds.mapio import read_map, write_map
from worlds.yamlio import InputError, atomic_write_text, dump_yaml, load_yaml
from sim.logs.tum import read_tum, write_tum
from slam.base import SlamResult

__all__ = ["write_result", "read_result"]

RESULT_FILES = ("map.yaml", "map.pgm", "trajectory.tum", "stats.json", "config.yaml")


def write_result(result: SlamResult, out_dir: str | os.PathLike) -> Path:
    """Write the files of a SLAM result into `out_dir` (created if needed); returns the directory."""
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{out}: cannot create output directory: {err.strerror}") from None
    write_map(result.grid, out / "map.yaml")
    write_tum(out / "trajectory.tum", result.times, result.poses)
    atomic_write_text(out / "stats.json", dumps(result.stats, indent=2, sort_keys=True) + "\n")
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
    stats = loads((out / "stats.json").read_text(), str(out / "stats.json"))
    config = load_yaml(out / "config.yaml") or {}
    return SlamResult(grid, t, poses, stats, config)
