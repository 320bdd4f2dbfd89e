"""`add_outside`: score a map (and a trajectory) made elsewhere into a bench run's results.

A ROS SLAM run on a bag exported from one of the run's logs (`python -m sim export`) saves a
map_server pair and, say, a TUM trajectory. The map is scored exactly as the runner scores its
own (bench.task._score against the run's stored true map and the world's surfaces, ICP from
identity: the exported odometry starts at the true start pose, so the map is in the world
frame), the trajectory
against the stored true path of the draw's log. The row, marked `source: "outside"`, joins
results.json under the run folder's lock, so the report shows the outside algorithm beside
the run's own.
"""
from __future__ import annotations

import datetime as _dt
import json
import platform
import re
import time
from pathlib import Path

import numpy as np

from worlds.yamlio import InputError, atomic_write_text
from bench.plan import RunSpec, Task, load_plugins, make_tasks
from bench.results import RESULTS_NAME, RUN_NAME, ResultStore, jsonable, read_rows
from bench.runner import map_path, read_run, read_truth, run_lock, write_npz
from bench.task import _score, new_row, score_trajectory

__all__ = ["add_outside", "SOURCE"]

SOURCE = "outside"
# the name becomes a folder under maps/ and part of figure file names
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]*")


def _load_npz(path: Path, what: str, *keys: str) -> dict:
    """The arrays `keys` of one of the run's .npz files; InputError if it is missing."""
    if not path.is_file():
        raise InputError(f"{path}: missing: the run's {what} is needed")
    with np.load(path) as z:
        return {k: z[k] for k in keys}


def _blank_keys() -> dict:
    """The run and trajectory keys of a runner row, None: an outside row may not know them."""
    from metrics import registry
    keys = [k for kind in ("run", "trajectory") for m in registry.metrics(kind) for k in m.keys]
    return {k: None for k in keys if k not in ("note", "ate_align")}


def _check_name(name: str, spec: RunSpec) -> None:
    from slam import registry
    load_plugins()
    if not _NAME.fullmatch(name or ""):
        raise InputError(f"--algo {name!r}: expected a name of letters, digits and _ . + - "
                         "(e.g. slam_toolbox)")
    if name in spec.algos:
        raise InputError(f"--algo {name}: an algorithm of this run ({', '.join(spec.algos)}); "
                         f"give the outside map another name (e.g. {name}_ros)")
    if name in registry.names():
        raise InputError(f"--algo {name}: the name of one of this project's algorithms; give "
                         f"the outside map another name (e.g. {name}_ros)")


def _draw_log_seed(spec: RunSpec, worlds: list[str], world: str, draw: int,
                   rows: list[dict]) -> int:
    """The log seed of `world`'s draw `draw` (its first repeat's log); InputError if the run
    has no such draw."""
    if spec.logs:  # the seeds are the logs' own, as the rows recorded them
        seeds = {int(r.get("draw", 0)): int(r["log_seed"]) for r in rows
                 if r["world"] == world and r.get("source") != SOURCE}
    else:
        seeds = {}
        for t in make_tasks(spec, worlds):
            if t.world == world:
                seeds.setdefault(t.draw, t.log_seed)
    if draw not in seeds:
        have = sorted(seeds)
        known = f"draws {have[0]}..{have[-1]}" if have else "no draws"
        raise InputError(f"--draw {draw}: out of range ({world} has {known} in this run)")
    return seeds[draw]


def add_outside(run_dir: str | Path, world: str, algo: str, map_yaml: str | Path,
                trajectory: str | Path | None = None, draw: int = 0, report: bool = True,
                figures: bool = True) -> dict:
    """Score MAP.yaml (and a TUM trajectory) as `algo` on `world`'s draw `draw` of the run in
    `run_dir`; store the row in results.json (run.json lists it under `added`), rebuild the
    report (bench.report.write_report) unless report=False, and return the row.

    InputError when run_dir is not a bench run, world is not one of its worlds, the name is
    one of its (or this project's) algorithms, the draw does not exist, or a file is bad.
    """
    from metrics import read_tum
    from worlds.mapio import read_map
    run_dir = Path(run_dir)
    run = read_run(run_dir)
    if not (run_dir / RESULTS_NAME).is_file():
        raise InputError(f"{run_dir}: no {RESULTS_NAME} here: not a bench run directory")
    try:
        spec = RunSpec.from_json(run["spec"])
        worlds = list(run["worlds"])
    except (KeyError, TypeError):
        raise InputError(f"{run_dir / RUN_NAME}: not a bench run description (no spec or "
                         "worlds)") from None
    if world not in worlds:
        raise InputError(f"--world {world}: not a world of this run (its worlds: "
                         f"{', '.join(worlds)})")
    _check_name(algo, spec)
    rows = read_rows(run_dir)
    log_seed = _draw_log_seed(spec, worlds, world, draw, rows)

    t0 = time.perf_counter()
    truth, surfaces = read_truth(run_dir, world)   # surfaces None: a run from before them
    grid = read_map(map_yaml)
    times, poses, gt = np.zeros(0), np.zeros((0, 3)), None
    if trajectory is not None:
        times, poses = read_tum(trajectory)
        gt = _load_npz(run_dir / "maps" / world / f"gt_s{log_seed}.npz",
                       f"true path of {world} log seed {log_seed}", "times", "poses")
    row = new_row(Task(world, algo, 0, log_seed, 0, draw), spec.noise, spec.vary)
    row.update(_blank_keys(), slam_seed=None, slam_stats={}, source=SOURCE,
               map_source=str(Path(map_yaml).resolve()),
               trajectory_source=str(Path(trajectory).resolve()) if gt is not None else None)
    row.update(_score(grid, truth, surfaces))
    if gt is not None:
        row.update(score_trajectory(times, poses, gt["times"], gt["poses"]))
    row["score_time_s"] = row["task_time_s"] = time.perf_counter() - t0
    row["worker"] = platform.node()

    with run_lock(run_dir):
        store = ResultStore(run_dir)
        row["repeat"] = 1 + max((r for w, a, r in store.rows if (w, a) == (world, algo)),
                                default=-1)
        p = map_path(run_dir, world, algo, row["repeat"])
        write_npz(p, prob=grid.prob, resolution=grid.resolution, origin=grid.origin,
                  times=times, poses=poses)
        row["map_file"] = str(p.relative_to(run_dir))
        row["finished_at"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        store.add(row)
        run = read_run(run_dir)
        run.setdefault("added", []).append(
            {"at": row["finished_at"], "world": world, "algo": algo, "repeat": row["repeat"],
             "draw": draw, "map": row["map_source"], "trajectory": row["trajectory_source"]})
        atomic_write_text(run_dir / RUN_NAME, json.dumps(jsonable(run), indent=1) + "\n")
        if report:
            from bench.report import write_report
            write_report(run_dir, figures=figures)
    return store.rows[(world, algo, row["repeat"])]
