"""`add_outside`: score a map (and a trajectory) made elsewhere into a bench run's results.

A ROS SLAM run on a bag exported from one of the run's logs (`python -m sim export`) saves a
map_server pair and, say, a TUM trajectory. The map is scored exactly as the runner scores its
own (bench.task._score against the run's stored true map and the world's surfaces, ICP from
identity: the exported odometry starts at the true start pose, so the map is in the world
frame), the trajectory against the stored true path of the draw's log. With render=True the
map is not taken from the outside SLAM but built from its trajectory and the draw's log with
this project's output map (`render_map`), as every algorithm's map is built here: the outside
SLAM is then compared pose for pose and map for map. The row, marked `source: "outside"`
(and `rendered`), joins results.json under the run folder's lock, so the report shows the
outside algorithm beside the run's own.

The trajectory must lie within the world's bounds (by bench.task's divergence margin); a map
without an occupied cell is stored as a failed row with `metrics score`'s reason for refusing
it (`empty_map_problem`).
"""
from __future__ import annotations

import datetime as _dt
import json
import platform
import time
from pathlib import Path

import numpy as np

from worlds.grid import OCCUPIED_THRESH
from worlds.paths import is_name, path_inside
from worlds.yamlio import InputError, atomic_write_text
from bench.plan import RunSpec, Task, load_plugins, make_tasks
from bench.results import (RESULTS_NAME, RUN_NAME, ResultStore, jsonable, read_rows, read_run,
                           run_spec)
from bench.rundir import map_path, read_truth, run_lock, truth_path, write_npz
from bench.task import DIVERGE_MARGIN_M, _score, new_row, score_trajectory

__all__ = ["add_outside", "render_map", "draw_log_path", "empty_map_problem", "SOURCE"]

SOURCE = "outside"
# TUM files print times to 1e-9 s or coarser: a scan at the trajectory's first or last stamp,
# rounded, must still count as inside its time span
_SPAN_SLACK_S = 1e-6


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
    if not is_name(name):   # it becomes a folder under maps/ and part of figure file names
        raise InputError(f"--algo {name!r}: expected a name of letters, digits and _ . + -, "
                         "not starting with a dot (e.g. slam_toolbox)")
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
        seeds = {int(r.get("draw") or 0): int(r["log_seed"]) for r in rows
                 if r["world"] == world and r.get("source") != SOURCE
                 and r.get("log_seed") is not None}
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


def draw_log_path(run_dir: Path, run: dict, spec: RunSpec, world: str, log_seed: int) -> Path:
    """The sensor log the run's `world` rows with `log_seed` ran on: the given file of a run
    over --logs, else the cached log (bench.cache.log_path, as the runner found it).
    InputError naming the file when it is not there any more."""
    from bench import cache
    if spec.logs:
        from bench.plan import read_log_set
        key_of = dict(zip(spec.worlds, run["worlds"]))   # the runner's keys, in its order
        found = [Path(p) for p, ref, seed, _ in read_log_set(",".join(spec.logs))
                 if key_of.get(ref) == world and seed == log_seed]
        if not found:
            raise InputError(f"{run_dir / RUN_NAME}: spec.logs: no log of {world} with seed "
                             f"{log_seed} among the run's logs")
        return found[0]
    import worlds as worlds_pkg
    entry = run["worlds"][world]
    file = str(entry.get("file") or "")
    w = worlds_pkg.load_world(file or entry.get("name") or world)
    path = cache.log_path(w, log_seed, spec.noise, Path(file) if file else None)
    if not path.is_file():
        raise InputError(f"{path}: missing: the sensor log of {world} log seed {log_seed} "
                         f"(noise {spec.noise}) is needed to render; it is not in the log cache "
                         "(another simulator version, another cache folder, or cleared)")
    return path


def empty_map_problem(grid, where: str) -> str | None:
    """Why `metrics score` refuses `grid` (read from `where`), in its words: no occupied cell
    at the default threshold, so precision and ADNN are undefined; None when it has one."""
    if grid.occupied(OCCUPIED_THRESH).any():
        return None
    return (f"{where}: the map has no occupied cell (p >= {OCCUPIED_THRESH}): precision and "
            "ADNN undefined")


def _world_bounds(run_dir: Path, world: str, truth) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) m of `world`: as the run stored them beside its true map, or
    (a run from before they were stored) the true map's extent."""
    with np.load(truth_path(run_dir, world)) as z:
        stored = np.asarray(z["bounds"], dtype=np.float64).reshape(-1) if "bounds" in z else None
    if stored is not None and stored.shape == (4,) and np.all(np.isfinite(stored)):
        return tuple(float(v) for v in stored)
    x0, y0 = float(truth.origin[0]), float(truth.origin[1])
    return (x0, y0, x0 + truth.width_m, y0 + truth.height_m)


def render_map(log, times: np.ndarray, poses: np.ndarray, where: str = "trajectory"):
    """This project's output map of `log`'s scans at the poses of an outside trajectory
    ((N,) times s, (N, 3) poses), interpolated at each scan's time; scans outside the
    trajectory's time span are left out. Returns a Grid; InputError (naming `where`) if no
    scan falls in the span."""
    from slam.output_map import OutputMapConfig, output_map_from_trajectory
    from slam.pose import interpolate_poses
    from slam.replay import scans_of
    inside = ((log.scan_t >= times[0] - _SPAN_SLACK_S)
              & (log.scan_t <= times[-1] + _SPAN_SLACK_S))
    if not inside.any():
        span = f"{log.scan_t[0]:.3f}..{log.scan_t[-1]:.3f} s" if log.n_scans else "no scans"
        raise InputError(f"{where}: t: the trajectory's times {times[0]:.3f}..{times[-1]:.3f} s "
                         f"cover none of the log's scans ({span})")
    scans = [scan for scan, keep in zip(scans_of(log), inside) if keep]
    t = log.scan_t[inside]
    return output_map_from_trajectory(OutputMapConfig(), scans, t,
                                      interpolate_poses(t, times, poses))


def add_outside(run_dir: str | Path, world: str, algo: str, map_yaml: str | Path | None = None,
                trajectory: str | Path | None = None, draw: int = 0, report: bool = True,
                figures: bool = True, render: bool = False) -> dict:
    """Score MAP.yaml (and a TUM trajectory) as `algo` on `world`'s draw `draw` of the run in
    `run_dir`; with render=True (and no map) score instead the map `render_map` builds from
    the trajectory and the draw's log. Store the row in results.json (run.json lists it under
    `added`), rebuild the report (bench.report.write_report) unless report=False, and return
    the row.

    InputError when run_dir is not a bench run, world is not one of its worlds, the name is
    one of its (or this project's) algorithms, the draw does not exist, a file is bad, the
    options do not fit (render with a map, render without a trajectory, neither map nor
    render) or, to render, the draw's log is not there any more.
    """
    _check_options(map_yaml, trajectory, render)
    run_dir = Path(run_dir)
    run, spec, log_seed = _open_run(run_dir, world, algo, draw)
    t0 = time.perf_counter()
    truth, surfaces = read_truth(run_dir, world)   # surfaces None: a run from before them
    grid, times, poses, gt = _outside_map(run_dir, run, spec, world, log_seed, map_yaml,
                                          trajectory, truth)
    row = new_row(Task(world, algo, 0, log_seed, 0, draw), spec.noise, spec.vary)
    row.update(_blank_keys(), slam_seed=None, slam_stats={}, source=SOURCE, rendered=render,
               map_source=None if render else str(Path(map_yaml).resolve()),
               trajectory_source=str(Path(trajectory).resolve()) if gt is not None else None)
    problem = empty_map_problem(grid, str(trajectory) if render else str(map_yaml))
    if problem:   # metrics score refuses such a map: the same verdict, stored as a failed row
        row.update(status="failed", error=problem)
    else:
        row.update(_score(grid, truth, surfaces))
    if gt is not None:
        row.update(score_trajectory(times, poses, gt["times"], gt["poses"]))
    row["score_time_s"] = row["task_time_s"] = time.perf_counter() - t0
    row["worker"] = platform.node()
    return _store(run_dir, row, grid, times, poses, report, figures)


def _check_options(map_yaml, trajectory, render: bool) -> None:
    """InputError unless exactly one of a map and a rendered trajectory is asked for."""
    if render and map_yaml is not None:
        raise InputError("--render builds the map from --trajectory: give --map or --render, "
                         "not both")
    if render and trajectory is None:
        raise InputError("--render needs --trajectory T.tum: the poses to build the map at")
    if not render and map_yaml is None:
        raise InputError("give --map MAP.yaml, or --trajectory T.tum with --render")


def _open_run(run_dir: Path, world: str, algo: str, draw: int) -> tuple[dict, RunSpec, int]:
    """(run.json, its spec, the log seed of `world`'s draw `draw`) of the run in `run_dir`;
    InputError when it is no run, or the world, name or draw do not fit it."""
    run = read_run(run_dir)
    if not (run_dir / RESULTS_NAME).is_file():
        raise InputError(f"{run_dir}: no {RESULTS_NAME} here: not a bench run directory")
    spec = run_spec(run, run_dir / RUN_NAME)
    worlds = list(run["worlds"])
    if world not in worlds:
        raise InputError(f"--world {world}: not a world of this run (its worlds: "
                         f"{', '.join(worlds)})")
    _check_name(algo, spec)
    return run, spec, _draw_log_seed(spec, worlds, world, draw, read_rows(run_dir))


def _outside_map(run_dir: Path, run: dict, spec: RunSpec, world: str, log_seed: int, map_yaml,
                 trajectory, truth):
    """(the map as a Grid, trajectory times (N,) s and poses (N, 3), the draw's true path
    {"times", "poses"} or None without a trajectory): the map read from `map_yaml`, or
    rendered from the trajectory and the draw's log when there is no map."""
    from metrics import read_tum
    from worlds.mapio import read_map
    grid = None if map_yaml is None else read_map(map_yaml)
    times, poses, gt = np.zeros(0), np.zeros((0, 3)), None
    if trajectory is not None:
        times, poses = read_tum(trajectory, bounds=_world_bounds(run_dir, world, truth),
                                margin=DIVERGE_MARGIN_M)
        gt = _load_npz(run_dir / "maps" / world / f"gt_s{log_seed}.npz",
                       f"true path of {world} log seed {log_seed}", "times", "poses")
    if map_yaml is None:
        from sim.logs import read_log
        log_file = draw_log_path(run_dir, run, spec, world, log_seed)
        grid = render_map(read_log(log_file), times, poses, str(trajectory))
    return grid, times, poses, gt


def _store(run_dir: Path, row: dict, grid, times, poses, report: bool, figures: bool) -> dict:
    """Under the run's lock: number the row (the next repeat of its world and name), write its
    map and trajectory, add it to results.json and run.json's `added`, rebuild the report;
    the row as stored."""
    world, algo = row["world"], row["algo"]
    with run_lock(run_dir):
        store = ResultStore(run_dir)
        row["repeat"] = 1 + max((r for w, a, r in store.rows if (w, a) == (world, algo)),
                                default=-1)
        p = map_path(run_dir, world, algo, row["repeat"])
        path_inside(run_dir, p.relative_to(run_dir))   # a symlinked folder must not lead out
        write_npz(p, prob=grid.prob, resolution=grid.resolution, origin=grid.origin,
                  times=times, poses=poses)
        row["map_file"] = str(p.relative_to(run_dir))
        row["finished_at"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        store.add(row)
        run = read_run(run_dir)
        run.setdefault("added", []).append(
            {"at": row["finished_at"], "world": world, "algo": algo, "repeat": row["repeat"],
             "draw": row["draw"], "map": row["map_source"],
             "trajectory": row["trajectory_source"], "rendered": row["rendered"]})
        atomic_write_text((run_dir / RUN_NAME).absolute(),
                          json.dumps(jsonable(run), indent=1) + "\n", root=run_dir)
        if report:
            from bench.report import write_report
            write_report(run_dir, figures=figures)
    return store.rows[(world, algo, row["repeat"])]
