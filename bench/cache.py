"""The sensor-log cache: a log is recorded once per (world file, seed, noise profile, simulator).

Key: sha256 of the world YAML's bytes, the log seed, the noise profile (its name, or the bytes
of its YAML file) and `sim.SIM_VERSION`; so editing a world or bumping the simulator never
reuses a stale log. Location: $SLAM_BENCH_CACHE, else $XDG_CACHE_HOME/slam-bench/logs, else
~/.cache/slam-bench/logs. Files are written atomically (write_log), so concurrent runs and
Ctrl-C never leave half a log.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

from worlds.yamlio import InputError

__all__ = ["cache_dir", "world_file", "world_digest", "noise_digest", "log_key", "log_path", "get_log"]


def cache_dir() -> Path:
    """The log cache directory (created on demand); InputError naming it if it cannot be."""
    env = os.environ.get("SLAM_BENCH_CACHE")
    if env:
        d = Path(env).expanduser()
    else:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        d = Path(base) / "slam-bench" / "logs"
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{d}: log cache: {err.strerror} (set SLAM_BENCH_CACHE to a folder "
                         "that can be written)") from None
    return d


def world_file(name_or_path: str) -> Path | None:
    """The YAML file a world name or path stands for (None if it cannot be found)."""
    p = Path(str(name_or_path)).expanduser()
    if p.is_file():
        return p.resolve()
    try:
        from worlds.load import world_dir
    except ImportError:
        return None
    q = world_dir() / f"{name_or_path}.yaml"
    return q if q.is_file() else None


def world_digest(world, path: str | Path | None = None) -> str:
    """sha256 of the world's YAML file (`path`, else World.source), else of its name."""
    src = str(path or getattr(world, "source", "") or "")
    h = hashlib.sha256()
    if src and Path(src).is_file():
        h.update(Path(src).read_bytes())
    else:
        h.update(f"world-name:{world.name}".encode())
    return h.hexdigest()


def noise_digest(noise: str) -> str:
    """A profile name stands for itself; a YAML path for its content."""
    p = Path(str(noise)).expanduser()
    if p.suffix in (".yaml", ".yml") and p.is_file():
        return "file:" + hashlib.sha256(p.read_bytes()).hexdigest()
    return f"name:{noise}"


def log_key(world, seed: int, noise: str, sim_version: str, path=None, lidar: str | None = None) -> str:
    """Cache key (hex) of the log of `world` (YAML file `path`) recorded with `seed`, `noise`
    and `lidar` (None: the default lidar, which adds nothing to the key) by `sim_version`."""
    h = hashlib.sha256()
    parts = [world_digest(world, path), str(int(seed)), noise_digest(noise), str(sim_version)]
    if lidar is not None:
        parts.append("lidar:" + noise_digest(lidar))
    for part in parts:
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:24]


def log_path(world, seed: int, noise: str, path=None, lidar: str | None = None) -> Path:
    """Where the cached log of (world from YAML `path`, seed, noise, lidar) lives under the
    current simulator version."""
    import sim
    key = log_key(world, seed, noise, sim.SIM_VERSION, path, lidar)
    return cache_dir() / f"{world.name}-s{int(seed)}-{key}.npz"


def get_log(world, seed: int, noise: str, path=None) -> Path:
    """Path of the cached log, recording and writing it first if missing."""
    import sim
    out = log_path(world, seed, noise, path)
    if not out.exists():
        sim.write_log(sim.record(world, seed=int(seed), noise=noise), out)
    return out
