"""The benchmark loop: worlds -> cached logs -> SLAM tasks in parallel -> rows as they finish.

`run_benchmark(spec, out_dir, ...)` loads and rasterizes each world (truth grid and visible
surfaces saved under DIR/maps/<world>/truth.npz), records each missing log once (in parallel
across worlds and seeds), submits a world's SLAM tasks as soon as its log exists, and stores
every finished row at once (results.json rewritten atomically, map and trajectory in
DIR/maps/<world>/<algo>/<repeat>.npz). Ctrl-C or a dead worker loses nothing stored;
`resume=True` runs only the rows missing from results.json, with the seeds of run.json.
A log that cannot be trusted (sim.recording_problem: the robot got stuck, the time limit
ran out, or the lidar saw less than spec.min_coverage of the true walls) runs no SLAM: its
rows are stored as failed with the reason, so they show in the report and in no average.
"""
from __future__ import annotations

import contextlib
import datetime as _dt
import fcntl
import io
import json
import os
import sys
import tempfile
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from worlds.paths import path_inside
from worlds.yamlio import InputError, atomic_write_bytes, atomic_write_text, short
from bench import cache
from bench.executors import make_executor
from bench.plan import (RunSpec, Task, config_dict, load_config_checked, load_plugins, make_tasks,
                        shard_tasks)
from bench.progress import Progress
from bench.results import RESULTS_NAME, RUN_NAME, ResultStore, jsonable, read_run, run_spec
from bench.task import WorldInfo, compile_algorithm, execute, new_row, record_log, versions

__all__ = ["run_benchmark", "RunOutcome", "load_worlds", "default_out_dir", "read_run",
           "map_path", "truth_path", "read_truth", "run_lock", "write_npz", "LOCK_NAME"]

LOCK_NAME = ".lock"   # held (flock) by the run writing into the folder; holds its pid


@dataclass
class RunOutcome:
    """How a run ended: rows stored now (ok / failed), total rows, interrupted or crashed."""

    out_dir: Path
    total: int
    ok: int
    failed: int
    interrupted: bool = False
    crashed: str | None = None

    @property
    def complete(self) -> bool:
        return self.ok + self.failed == self.total and not self.interrupted and not self.crashed


# cold numba compile cost of the built-in algorithms (s, this machine: pf 12, graph 8, gn 4,
# oracle 1); the compile jobs go out heaviest first so the workers finish them together
COMPILE_ORDER = {"pf": 12.0, "graph": 8.0, "gn": 4.0, "oracle": 1.0}


def default_out_dir() -> Path:
    """runs/<UTC timestamp> under the current directory."""
    return Path("runs") / _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d-%H%M%S")


def map_path(out_dir: Path, world: str, algo: str, repeat: int) -> Path:
    """DIR/maps/WORLD/ALGO/REPEAT.npz; InputError when the names would lead outside DIR."""
    return path_inside(out_dir, "maps", world, algo, f"{int(repeat)}.npz",
                       what=f"{out_dir}: map of {short(world)}/{short(algo)}")


def truth_path(out_dir: Path, world: str) -> Path:
    """DIR/maps/WORLD/truth.npz; InputError when the name would lead outside DIR."""
    return path_inside(out_dir, "maps", world, "truth.npz", what=f"{out_dir}: truth of {short(world)}")


def load_worlds(names: list[str]):
    """World names/paths -> ({key: World}, {key: YAML file or None}); keys are the world
    names, made unique if two differ only by path."""
    import worlds
    out, files = {}, {}
    for name in names:
        try:
            w = worlds.load_world(name)
        except InputError as err:
            msg = str(err)
            raise InputError(msg if msg.startswith(str(name)) else f"--world {name}: {msg}") from None
        key = w.name
        i = 2
        while key in out:
            key = f"{w.name}_{i}"
            i += 1
        out[key] = w
        files[key] = cache.world_file(name)
    return out, files


def check_run_dir(out_dir: Path, resume: bool) -> None:
    """InputError unless `out_dir` can take a new run (no results yet) or, with `resume`, holds one."""
    holds = [n for n in (RESULTS_NAME, RUN_NAME) if (out_dir / n).exists()]
    if holds and not resume:
        raise InputError(f"{out_dir} already holds another run's results ({', '.join(holds)}); "
                         f"use --resume {out_dir} to complete it, or choose another --out")
    if resume and not (out_dir / RUN_NAME).exists():
        raise InputError(f"--resume {out_dir}: no {RUN_NAME} there: nothing to resume")


def _check_cache_writable(spec: RunSpec, world_map: dict, world_files: dict) -> None:
    """InputError naming the log cache when a log must be recorded and the cache cannot take
    it (checked by writing, so a read-only folder is caught for root too); a read-only cache
    that holds every log is fine."""
    needed = {(t.world, t.log_seed) for t in make_tasks(spec, list(world_map))}
    if all(cache.log_path(world_map[w], s, spec.noise, world_files[w]).exists() for w, s in needed):
        return
    folder = cache.cache_dir()
    try:
        probe = tempfile.NamedTemporaryFile(dir=folder, prefix=".probe.")
        probe.close()
    except OSError as err:
        raise InputError(f"{folder}: log cache: {err.strerror or err} (set SLAM_BENCH_CACHE to a "
                         "folder that can be written)") from None


def write_npz(path: Path, **arrays) -> None:
    """A compressed .npz written atomically under a unique temporary name."""
    buf = io.BytesIO()
    np.savez_compressed(buf, **{k: np.asarray(v) for k, v in arrays.items()})
    atomic_write_bytes(path, buf.getvalue())


def _save_truth(out_dir: Path, key: str, world, truth) -> None:
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


def _save_gt(out_dir: Path, key: str, seed: int, log) -> None:
    """True trajectory of the log (for the trajectory figure), once per world and log seed."""
    p = path_inside(out_dir, "maps", key, f"gt_s{int(seed)}.npz", what=f"true trajectory of {short(key)}")
    if not p.exists() and log is not None and log.has_ground_truth:
        write_npz(p, times=log.gt_t, poses=log.gt_pose)


def _save_arrays(out_dir: Path, task: Task, arrays: dict | None) -> str | None:
    if arrays is None:
        return None
    p = map_path(out_dir, task.world, task.algo, task.repeat)
    write_npz(p, **arrays)
    return str(p.relative_to(out_dir))


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


def _write_run_json(out_dir: Path, spec: RunSpec, world_map: dict, world_files: dict, argv: list[str] | None,
                    resumed_from: dict | None) -> None:
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
    if resumed_from is not None:
        data.setdefault("resumed", []).append({
            "at": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "command": ["python", "-m", "bench", *(argv or [])]})
    else:
        data["started"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out_dir / RUN_NAME, json.dumps(jsonable(data), indent=1) + "\n")


def run_benchmark(spec: RunSpec, out_dir: str | Path, jobs: int | None = None,
                  scheduler: str | None = None, resume: bool = False, progress: bool = True,
                  argv: list[str] | None = None, stream=None) -> RunOutcome:
    """Run (or, with resume=True, complete) the benchmark `spec` into `out_dir`.

    jobs: worker processes (default: all cores; 1 runs in this process); scheduler: a Dask
    scheduler address ('local' for a LocalCluster). Returns a RunOutcome; user errors raise
    InputError before any work starts.
    """
    out_dir = Path(out_dir)
    with run_lock(out_dir):
        return _run_locked(spec, out_dir, jobs, scheduler, resume, progress, argv, stream)


def _check_inputs(spec: RunSpec):
    """Load every file the run names (configs, noise profile, worlds) before any work, so a
    bad one fails now; the worlds as load_worlds gives them."""
    load_plugins()
    for algo in spec.algos:
        load_config_checked(algo, spec.configs.get(algo), spec.overrides.get(algo))
    import sim
    if hasattr(sim, "load_profile") and not spec.logs:
        sim.load_profile(spec.noise)
    return load_worlds(list(spec.worlds))


def _run_locked(spec: RunSpec, out_dir: Path, jobs, scheduler, resume, progress, argv,
                stream) -> RunOutcome:
    check_run_dir(out_dir, resume)
    previous = read_run(out_dir) if resume else None
    if previous is not None and run_spec(previous, out_dir / RUN_NAME) != spec:
        raise InputError(f"--resume {out_dir}: the run was started with other arguments; "
                         "resume it without --world/--algo/--repeats/--seed/--noise/--vary/--config")
    try:
        world_map, world_files = _check_inputs(spec)
    except InputError as err:
        if previous is None:
            raise
        # the files a resumed run names come from its run.json, not from the command line
        raise InputError(f"{out_dir / RUN_NAME}: spec: {err}") from None
    import sim
    if not spec.logs:
        _check_cache_writable(spec, world_map, world_files)
    _write_run_json(out_dir, spec, world_map, world_files, argv, previous)
    store = ResultStore(out_dir)

    import worlds
    infos = {}
    for key, w in world_map.items():
        truth = worlds.rasterize(w)
        infos[key] = WorldInfo(key, truth, tuple(float(v) for v in w.bounds), str(w.source or ""),
                               np.asarray(w.visible_segments, dtype=np.float64).reshape(-1, 4))
        _save_truth(out_dir, key, w, truth)
    configs = {a: load_config_checked(a, spec.configs.get(a), spec.overrides.get(a))
               for a in spec.algos}
    from slam import registry
    algo_classes = {a: registry.get(a) for a in spec.algos}

    # --logs: the given files are the logs (world key, seed) -> path; nothing is recorded
    key_of = dict(zip(spec.worlds, world_map))
    given = {}
    if spec.logs:
        from bench.plan import read_log_set
        given = {(key_of[world], seed): Path(path)
                 for path, world, seed, _ in read_log_set(",".join(spec.logs))}
    all_tasks = shard_tasks(make_tasks(spec, list(world_map), list(given) if spec.logs else None),
                            spec.shard)
    todo = [t for t in all_tasks if t.key not in store]
    by_log: dict[tuple[str, int], list[Task]] = {}
    for t in todo:
        by_log.setdefault((t.world, t.log_seed), []).append(t)

    bar = Progress(len(todo), already=len(all_tasks) - len(todo), stream=stream, enabled=progress)
    outcome = RunOutcome(out_dir, len(all_tasks), 0, 0)
    for row in store.rows.values():
        if row.get("source") == "outside":
            continue  # added by `bench add`, not a task of this run
        if row.get("status") == "ok":
            outcome.ok += 1
        else:
            outcome.failed += 1
    if not todo:
        bar.close()
        return outcome

    ex = make_executor(jobs, scheduler)
    remote = scheduler is not None
    pending: dict = {}  # future -> ("log", (world, seed)) | ("task", Task) | ("compile", algo)
    shared: dict = {}   # scattered world infos / configs (Dask: sent once)

    def world_handle(key):
        if key not in shared:
            shared[key] = ex.scatter(infos[key]) if remote else infos[key]
        return shared[key]

    warming: set = set()      # futures of compile jobs still running
    deferred: list = []       # (log key, log source) whose tasks wait for the compile jobs
    compile_started = False

    def submit_tasks(lkey, log_source):
        nonlocal compile_started
        if not compile_started:
            # One compile job per algorithm, heaviest first, before any SLAM task: the workers
            # compile side by side instead of each compiling every algorithm itself.
            compile_started = True
            for a in sorted(spec.algos, key=lambda a: -COMPILE_ORDER.get(a, 0)):
                fut = ex.submit(compile_algorithm, a, log_source, configs[a], algo_classes[a])
                pending[fut] = ("compile", a)
                warming.add(fut)
        if warming:
            deferred.append((lkey, log_source))
            return
        for t in by_log[lkey]:
            fut = ex.submit(execute, t, world_handle(t.world), log_source, configs[t.algo],
                            spec.noise, spec.vary, algo_classes[t.algo])
            pending[fut] = ("task", t)

    def log_ready(lkey, path, log=None):
        if log is None:
            log = _read(path)  # cheap next to a SLAM run; gives the true path for the figures
        _save_gt(out_dir, lkey[0], lkey[1], log)
        problem = sim.recording_problem(log.meta, spec.min_coverage)
        if problem is None:
            submit_tasks(lkey, ex.scatter(log) if remote else str(path))
            return
        bar.note(f"{lkey[0]} seed {lkey[1]}: {problem}")
        for t in by_log[lkey]:
            row = new_row(t, spec.noise, spec.vary)
            row.update(status="failed", error=problem, map_file=None,
                       finished_at=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))
            store.add(row)
            outcome.failed += 1
            bar.advance(t.label + f" ({problem[:50]})", False)

    try:
        for lkey in by_log:
            key, seed = lkey
            path = given.get(lkey) or cache.log_path(world_map[key], seed, spec.noise,
                                                     world_files[key])
            if path.exists():
                log_ready(lkey, path)
            else:
                bar.note(f"recording {key} seed {seed}")
                pending[ex.submit(record_log, world_map[key], seed, spec.noise)] = ("log", lkey)
        while pending:
            done, _ = ex.wait_any(list(pending))
            for fut in done:
                kind, what = pending.pop(fut)
                if kind == "compile":
                    warming.discard(fut)
                    if not warming:
                        for args in deferred:
                            submit_tasks(*args)
                        deferred.clear()
                    continue
                if kind == "log":
                    log = ex.result(fut)
                    path = cache.log_path(world_map[what[0]], what[1], spec.noise, world_files[what[0]])
                    sim.write_log(log, path)
                    log_ready(what, path, log)
                    continue
                row, arrays = ex.result(fut)
                row["map_file"] = _save_arrays(out_dir, what, arrays)
                row["finished_at"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
                store.add(row)
                ok = row["status"] == "ok"
                outcome.ok += ok
                outcome.failed += not ok
                bar.advance(what.label + ("" if ok else f" ({str(row['error'])[:50]})"), ok)
    except KeyboardInterrupt:
        outcome.interrupted = True
    except BrokenProcessPool as err:
        outcome.crashed = f"a worker process died ({err})"
    finally:
        bar.close()
        ex.shutdown(cancel=bool(pending))
    return outcome


def _read(path):
    from sim.logs import read_log
    return read_log(path)


def print_outcome(outcome: RunOutcome, stream=None) -> None:
    """One summary line for the end of a run (and how to resume an unfinished one)."""
    stream = stream or sys.stderr
    done = outcome.ok + outcome.failed
    msg = f"{done}/{outcome.total} rows ({outcome.failed} failed) in {outcome.out_dir}"
    if outcome.interrupted:
        msg = f"interrupted: {msg}; complete it with: python -m bench run --resume {outcome.out_dir}"
    elif outcome.crashed:
        msg = f"{outcome.crashed}: {msg}; complete it with: python -m bench run --resume {outcome.out_dir}"
    print(msg, file=stream)
