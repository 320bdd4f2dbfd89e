"""A run's folder: what `bench run` writes besides results.json (bench.results), apart from
how the work is scheduled (bench.runner).

DIR/run.json      the spec, command, versions, worlds and effective configs (resumes append)
DIR/.lock         held (flock, the holder's pid inside) while a run or `bench add` writes
DIR/maps/WORLD/truth.npz              the true grid, bounds and visible surfaces
DIR/maps/WORLD/gt_s<SEED>.npz         the true trajectory of log seed SEED (for the figures)
DIR/maps/WORLD/ALGO/<REPEAT>.npz      a run's map and trajectory
Every array file is written atomically under a unique temporary name: a kill mid-write
leaves no partial file that a resume would take as done.
"""
from __future__ import annotations

import contextlib
import datetime as _dt
import fcntl
import io
import json
import os
from pathlib import Path

import numpy as np

from worlds.paths import path_inside
from worlds.yamlio import InputError, atomic_write_bytes, atomic_write_text, short
from bench.plan import RunSpec, Task, config_dict
from bench.results import RESULTS_NAME, RUN_NAME, jsonable
from bench.task import versions

__all__ = ["LOCK_NAME", "run_lock", "default_out_dir", "check_run_dir", "map_path", "truth_path",
           "read_truth", "write_npz", "save_truth", "save_gt", "save_arrays", "write_run_json"]

LOCK_NAME = ".lock"   # held (flock) by the run writing into the folder; holds its pid


def default_out_dir() -> Path:
    """runs/<UTC timestamp> under the current directory."""
    return Path("runs") / _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d-%H%M%S")


def check_run_dir(out_dir: Path, resume: bool) -> None:
    """InputError unless `out_dir` can take a new run (no results yet) or, with `resume`, holds one."""
    holds = [n for n in (RESULTS_NAME, RUN_NAME) if (out_dir / n).exists()]
    if holds and not resume:
        raise InputError(f"{out_dir} already holds another run's results ({', '.join(holds)}); "
                         f"use --resume {out_dir} to complete it, or choose another --out")
    if resume and not (out_dir / RUN_NAME).exists():
        raise InputError(f"--resume {out_dir}: no {RUN_NAME} there: nothing to resume")


@contextlib.contextmanager
def run_lock(out_dir: Path):
    """Hold DIR/.lock (an exclusive flock holding the pid) while a run writes into DIR; a second
    run on the same folder gets an InputError naming the holder's pid."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            raise InputError(f"{out_dir}: in use by another bench run (pid {holder}); wait for it "
                             "to finish or stop it") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)


def map_path(out_dir: Path, world: str, algo: str, repeat: int) -> Path:
    """DIR/maps/WORLD/ALGO/REPEAT.npz; InputError when the names would lead outside DIR."""
    return path_inside(out_dir, "maps", world, algo, f"{int(repeat)}.npz",
                       what=f"{out_dir}: map of {short(world)}/{short(algo)}")


def truth_path(out_dir: Path, world: str) -> Path:
    """DIR/maps/WORLD/truth.npz; InputError when the name would lead outside DIR."""
    return path_inside(out_dir, "maps", world, "truth.npz", what=f"{out_dir}: truth of {short(world)}")


def write_npz(path: Path, **arrays) -> None:
    """A compressed .npz written atomically under a unique temporary name."""
    buf = io.BytesIO()
    np.savez_compressed(buf, **{k: np.asarray(v) for k, v in arrays.items()})
    atomic_write_bytes(path, buf.getvalue())


def save_truth(out_dir: Path, key: str, world, truth) -> None:
    """World `key`'s true Grid `truth`, bounds and visible surfaces (of the World `world`)."""
    write_npz(truth_path(out_dir, key), prob=truth.prob, resolution=truth.resolution,
              origin=truth.origin, bounds=np.asarray(world.bounds, dtype=np.float64),
              surfaces=np.asarray(world.visible_segments, dtype=np.float64).reshape(-1, 4))


def read_truth(out_dir: Path, key: str):
    """(true Grid, visible surfaces (S, 4) m or None) of world `key` stored by a run; a run
    written before the surfaces were stored gives None (its maps are scored in the cell form).
    InputError if the file is missing."""
    from worlds.grid import Grid
    p = truth_path(out_dir, key)
    if not p.is_file():
        raise InputError(f"{p}: missing: the run's true map of {key} is needed")
    with np.load(p) as z:
        grid = Grid(z["prob"], float(z["resolution"]), z["origin"])
        surfaces = np.asarray(z["surfaces"], dtype=np.float64) if "surfaces" in z else None
    return grid, surfaces


def save_gt(out_dir: Path, key: str, seed: int, log) -> None:
    """True trajectory of the log (for the trajectory figure), once per world and log seed."""
    p = path_inside(out_dir, "maps", key, f"gt_s{int(seed)}.npz", what=f"true trajectory of {short(key)}")
    if not p.exists() and log is not None and log.has_ground_truth:
        write_npz(p, times=log.gt_t, poses=log.gt_pose)


def save_arrays(out_dir: Path, task: Task, arrays: dict | None) -> str | None:
    """A task's map and trajectory arrays at its map_path; the path relative to DIR (the row's
    map_file), None when the task gave none."""
    if arrays is None:
        return None
    p = map_path(out_dir, task.world, task.algo, task.repeat)
    write_npz(p, **arrays)
    return str(p.relative_to(out_dir))


def write_run_json(out_dir: Path, spec: RunSpec, world_map: dict, world_files: dict,
                   argv: list[str] | None, resumed_from: dict | None) -> None:
    """DIR/run.json of a new run, or `resumed_from` (the run.json read) with this resume noted."""
    data = resumed_from or {}
    data.update({
        "spec": spec.to_json(),
        "command": data.get("command") or ["python", "-m", "bench", *(argv or [])],
        "versions": versions(),
        "worlds": {k: {"name": w.name, "file": str(world_files[k] or "")}
                   for k, w in world_map.items()},
        "configs": {a: config_dict(a, spec.configs.get(a), spec.overrides.get(a))
                    for a in spec.algos},
    })
    now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    if resumed_from is not None:
        data.setdefault("resumed", []).append(
            {"at": now, "command": ["python", "-m", "bench", *(argv or [])]})
    else:
        data["started"] = now
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out_dir / RUN_NAME, json.dumps(jsonable(data), indent=1) + "\n")
