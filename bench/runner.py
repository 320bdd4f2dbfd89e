"""The benchmark loop: worlds -> cached logs -> SLAM tasks in parallel -> rows as they finish.

`run_benchmark(spec, out_dir, ...)` loads and rasterizes each world (truth grid and visible
surfaces saved under DIR/maps/<world>/truth.npz), records each missing log once (in parallel
across worlds and seeds), submits a world's SLAM tasks as soon as its log exists, and stores
every finished row at once (results.json rewritten atomically, map and trajectory in
DIR/maps/<world>/<algo>/<repeat>.npz; the folder's files: bench.rundir). Ctrl-C or a dead
worker loses nothing stored; `resume=True` runs only the rows missing from results.json, with
the seeds of run.json. A log that cannot be trusted (sim.recording_problem: the robot got
stuck, the time limit ran out, or the lidar saw less than spec.min_coverage of the true walls)
runs no SLAM: its rows are stored as failed with the reason, so they show in the report and in
no average.

The run reads as its steps: `_open_run` (the folder, the spec of a resumed run, every input
checked), `_prepare` (the worlds' truths, the configs, the tasks still to do: a RunPlan), then
a `Scheduler` whose methods are the events of the run (a log is ready, the compile jobs are
done, a task is done).
"""
from __future__ import annotations

import datetime as _dt
import sys
import tempfile
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from worlds.paths import check_name, names_a_file
from worlds.yamlio import InputError
from bench import cache
from bench.executors import make_executor
from bench.plan import (RunSpec, Task, load_config_checked, load_plugins, make_tasks, shard_tasks,
                        user_config)
from bench.progress import Progress
from bench.results import RUN_NAME, ResultStore, read_run, run_spec
from bench.rundir import check_run_dir, run_lock, save_arrays, save_gt, save_truth, write_run_json
from bench.task import WorldInfo, compile_algorithm, compile_scoring, execute, new_row, record_log

__all__ = ["run_benchmark", "RunOutcome", "RunPlan", "Scheduler", "load_worlds", "cross_lidars",
           "print_outcome"]


@dataclass
class RunOutcome:
    """How a run ended: rows stored now (ok / failed), total rows, interrupted or crashed."""

    out_dir: Path
    total: int
    ok: int
    failed: int
    interrupted: bool = False
    crashed: str | None = None
    stopped: bool = False   # on_row asked the run to stop (bench tune prunes a trial)

    @property
    def complete(self) -> bool:
        return (self.ok + self.failed == self.total and not self.interrupted and not self.crashed
                and not self.stopped)


@dataclass
class RunPlan:
    """What a run needs, prepared before any job is sent: the worlds (World, YAML file, what a
    worker gets of each), each algorithm's config and class, the given logs of a --logs run
    ((world key, seed) -> path), the tasks still to do grouped by their log, and the count of
    all tasks of the run (its shard)."""

    spec: RunSpec
    out_dir: Path
    worlds: dict
    world_files: dict
    lidars: dict            # world key -> the lidar its logs are recorded with (None: default)
    infos: dict[str, WorldInfo]
    configs: dict
    classes: dict[str, type]
    given: dict[tuple[str, int], Path]
    by_log: dict[tuple[str, int], list[Task]] = field(default_factory=dict)
    total: int = 0

    def log_path(self, lkey: tuple[str, int]) -> Path:
        """Where the log of (world key, log seed) is: the given file, else the log cache."""
        return self.given.get(lkey) or self.cached_log_path(lkey)

    def cached_log_path(self, lkey: tuple[str, int]) -> Path:
        """Where the log cache keeps (or a recording puts) the log of (world key, log seed)."""
        key, seed = lkey
        return cache.log_path(self.worlds[key], seed, self.spec.noise, self.world_files[key],
                              self.lidars.get(key))

    def compile_order(self) -> list[str]:
        """The run's algorithms, the costliest to compile first (Slam.compile_cost_s)."""
        return sorted(self.spec.algos, key=lambda a: -self.classes[a].compile_cost_s)


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


def cross_lidars(world_map: dict, world_files: dict, lidars) -> tuple[dict, dict, dict]:
    """Each world crossed with each lidar: ({WORLD+LIDAR: World}, {...: YAML file},
    {...: lidar}); without lidars the maps as given, every lidar None (the default). The key's
    lidar part is the catalogue name, or a lidar file's stem."""
    if not lidars:
        return world_map, world_files, {k: None for k in world_map}
    labels = {}
    for lidar in lidars:
        label = Path(lidar).stem if names_a_file(lidar) else lidar
        check_name(label, f"--lidar {lidar}", "the lidar's name in world keys")
        if label in labels.values():
            raise InputError(f"--lidar {lidar}: another lidar of the run is also named "
                             f"'{label}'; rename one of the files")
        labels[lidar] = label
    out, files, of = {}, {}, {}
    for key, w in world_map.items():
        for lidar in lidars:
            k = f"{key}+{labels[lidar]}"
            out[k], files[k], of[k] = w, world_files[key], lidar
    return out, files, of


def _check_cache_writable(spec: RunSpec, world_map: dict, world_files: dict,
                          lidar_of: dict) -> None:
    """InputError naming the log cache when a log must be recorded and the cache cannot take
    it (checked by writing, so a read-only folder is caught for root too); a read-only cache
    that holds every log is fine."""
    needed = {(t.world, t.log_seed) for t in make_tasks(spec, list(world_map))}
    if all(cache.log_path(world_map[w], s, spec.noise, world_files[w], lidar_of[w]).exists()
           for w, s in needed):
        return
    folder = cache.cache_dir()
    try:
        probe = tempfile.NamedTemporaryFile(dir=folder, prefix=".probe.")
        probe.close()
    except OSError as err:
        raise InputError(f"{folder}: log cache: {err.strerror or err} (set SLAM_BENCH_CACHE to a "
                         "folder that can be written)") from None


def _check_inputs(spec: RunSpec):
    """Load every file the run names (configs, noise profile, worlds) before any work, so a
    bad one fails now; the worlds as load_worlds gives them."""
    load_plugins()
    for algo in spec.algos:
        load_config_checked(algo, spec.configs.get(algo), spec.overrides.get(algo))
    import sim
    if hasattr(sim, "load_profile") and not spec.logs:
        sim.load_profile(spec.noise)
        for lidar in spec.lidars:
            sim.load_lidar(lidar)
    return cross_lidars(*load_worlds(list(spec.worlds)), spec.lidars)


def run_benchmark(spec: RunSpec, out_dir: str | Path, jobs: int | None = None,
                  scheduler: str | None = None, resume: bool = False, progress: bool = True,
                  argv: list[str] | None = None, stream=None, on_row=None) -> RunOutcome:
    """Run (or, with resume=True, complete) the benchmark `spec` into `out_dir`.

    jobs: worker processes (default: all cores; 1 runs in this process); scheduler: a Dask
    scheduler address ('local' for a LocalCluster); on_row: called with each row once it is
    stored, and a true return stops the run (its pending jobs cancelled, outcome.stopped).
    Returns a RunOutcome; user errors raise InputError before any work starts.
    """
    out_dir = Path(out_dir)
    with run_lock(out_dir):
        world_map, world_files, lidar_of = _open_run(spec, out_dir, resume, argv)
        store = ResultStore(out_dir)
        plan = _prepare(spec, out_dir, world_map, world_files, lidar_of, store)
        todo = sum(len(ts) for ts in plan.by_log.values())
        bar = Progress(todo, already=plan.total - todo, stream=stream, enabled=progress)
        outcome = _stored_outcome(out_dir, plan.total, store)
        if not todo:
            bar.close()
            return outcome
        return Scheduler(plan, store, bar, outcome, make_executor(jobs, scheduler),
                         remote=scheduler is not None, on_row=on_row).run()


def _open_run(spec: RunSpec, out_dir: Path, resume: bool, argv) -> tuple[dict, dict, dict]:
    """Check the folder (and that a resumed run's spec is `spec`) and every input, then write
    run.json; the worlds as load_worlds gives them."""
    check_run_dir(out_dir, resume)
    previous = read_run(out_dir) if resume else None
    if previous is not None and run_spec(previous, out_dir / RUN_NAME) != spec:
        raise InputError(f"--resume {out_dir}: the run was started with other arguments; "
                         "resume it without --world/--algo/--repeats/--seed/--noise/--vary/--config")
    try:
        world_map, world_files, lidar_of = _check_inputs(spec)
    except InputError as err:
        if previous is None:
            raise
        # the files a resumed run names come from its run.json, not from the command line
        raise InputError(f"{out_dir / RUN_NAME}: spec: {err}") from None
    if not spec.logs:
        _check_cache_writable(spec, world_map, world_files, lidar_of)
    write_run_json(out_dir, spec, world_map, world_files, argv, previous)
    return world_map, world_files, lidar_of


def _prepare(spec: RunSpec, out_dir: Path, world_map: dict, world_files: dict, lidar_of: dict,
             store: ResultStore) -> RunPlan:
    """The RunPlan of the tasks not in `store`; each world's truth is rasterized and saved."""
    import worlds
    infos = {}
    for key, w in world_map.items():
        truth = worlds.rasterize(w)
        infos[key] = WorldInfo(key, truth, tuple(float(v) for v in w.bounds), str(w.source or ""),
                               np.asarray(w.visible_segments, dtype=np.float64).reshape(-1, 4))
        save_truth(out_dir, key, w, truth)
    configs = {a: user_config(a, spec.configs.get(a), spec.overrides.get(a)) for a in spec.algos}
    from slam import registry
    plan = RunPlan(spec, out_dir, world_map, world_files, lidar_of, infos, configs,
                   {a: registry.get(a) for a in spec.algos}, _given_logs(spec, world_map))
    all_tasks = shard_tasks(make_tasks(spec, list(world_map),
                                       list(plan.given) if spec.logs else None), spec.shard)
    plan.total = len(all_tasks)
    for t in all_tasks:
        if t.key not in store:
            plan.by_log.setdefault((t.world, t.log_seed), []).append(t)
    return plan


def _given_logs(spec: RunSpec, world_map: dict) -> dict[tuple[str, int], Path]:
    """--logs: the given files are the logs, (world key, seed) -> path; {} otherwise."""
    if not spec.logs:
        return {}
    from bench.plan import read_log_set
    key_of = dict(zip(spec.worlds, world_map))
    return {(key_of[world], seed): Path(path)
            for path, world, seed, _ in read_log_set(",".join(spec.logs))}


def _stored_outcome(out_dir: Path, total: int, store: ResultStore) -> RunOutcome:
    """The outcome before any job: the run's rows already stored (a resume), ok or failed."""
    outcome = RunOutcome(out_dir, total, 0, 0)
    for row in store.rows.values():
        if row.get("source") == "outside":
            continue  # added by `bench add`, not a task of this run
        if row.get("status") == "ok":
            outcome.ok += 1
        else:
            outcome.failed += 1
    return outcome


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


class Scheduler:
    """Sends a run's jobs to the executor as their inputs become ready; each method named for
    an event handles it.

    `run` looks for every log (found in the cache or given: `log_ready`; else a recording job,
    whose end is `log_recorded`). The first ready log sends one compile job per algorithm,
    costliest first, and after the first of them one for the output map and the metrics every
    task shares (on that log's head), so the workers compile side by side instead of each
    compiling every algorithm itself; a ready log's SLAM tasks wait until every compile job is
    done (`compile_done`). A log that cannot be trusted gives failed rows instead of tasks. Each
    finished task (`task_done`) stores its row and arrays at once. A deterministic algorithm
    (Slam.deterministic) runs once per log: its other tasks there differ only in the SLAM seed
    and take that run's row, marked `same_as` its repeat.
    """

    def __init__(self, plan: RunPlan, store: ResultStore, bar: Progress, outcome: RunOutcome,
                 ex, remote: bool = False, on_row=None):
        self.plan, self.spec, self.store = plan, plan.spec, store
        self.on_row = on_row
        self.bar, self.outcome = bar, outcome
        self.ex, self.remote = ex, remote
        self.pending: dict = {}   # future -> (event method, what it finished)
        self.shared: dict = {}    # world key -> its WorldInfo as sent (Dask: scattered once)
        self.warming: set = set()   # compile jobs still running
        self.waiting: list = []     # (log key, log source) whose tasks wait for the compile jobs
        self.compile_started = False
        self.followers: dict = {}   # task key -> tasks that take its row (deterministic algorithms)

    def run(self) -> RunOutcome:
        """Every job of the plan, until none is pending (or Ctrl-C, or a worker died)."""
        try:
            for lkey in self.plan.by_log:
                path = self.plan.log_path(lkey)
                if path.exists():
                    self.log_ready(lkey, path)
                else:
                    self.bar.note(f"recording {lkey[0]} seed {lkey[1]}")
                    self._submit(self.log_recorded, lkey, record_log,
                                 self.plan.worlds[lkey[0]], lkey[1], self.spec.noise,
                                 self.plan.lidars.get(lkey[0]))
            while self.pending:
                done, _ = self.ex.wait_any(list(self.pending))
                for fut in done:
                    event, what = self.pending.pop(fut)
                    event(fut, what)
        except _StopRun:
            self.outcome.stopped = True
        except KeyboardInterrupt:
            self.outcome.interrupted = True
        except BrokenProcessPool as err:
            self.outcome.crashed = f"a worker process died ({err})"
        finally:
            self.bar.close()
            self.ex.shutdown(cancel=bool(self.pending))
        return self.outcome

    def _submit(self, event, what, fn, *args):
        fut = self.ex.submit(fn, *args)
        self.pending[fut] = (event, what)
        return fut

    def log_recorded(self, fut, lkey: tuple[str, int]) -> None:
        """A recording job ended: write its log into the cache, then it is ready."""
        import sim
        log = self.ex.result(fut)
        path = self.plan.cached_log_path(lkey)
        sim.write_log(log, path)
        self.log_ready(lkey, path, log)

    def log_ready(self, lkey: tuple[str, int], path: Path, log=None) -> None:
        """The log of (world key, seed) is at `path`: save its true path, then send its tasks,
        or store them as failed when the log cannot be trusted."""
        import sim
        if log is None:
            log = _read(path)  # cheap next to a SLAM run; gives the true path for the figures
        save_gt(self.plan.out_dir, lkey[0], lkey[1], log)
        problem = sim.recording_problem(log.meta, self.spec.min_coverage)
        if problem is None:
            self._send_tasks(lkey, self.ex.scatter(log) if self.remote else str(path))
        else:
            self._fail_tasks(lkey, problem)

    def _send_tasks(self, lkey: tuple[str, int], log_source) -> None:
        if not self.compile_started:
            self.compile_started = True
            for n, a in enumerate(self.plan.compile_order()):
                self.warming.add(self._submit(self.compile_done, a, compile_algorithm, a,
                                              log_source, self.plan.configs[a],
                                              self.plan.classes[a]))
                if n == 0:
                    # the kernels every task shares, beside the costliest algorithm's, so
                    # the other algorithms' jobs find them compiled
                    self.warming.add(self._submit(self.compile_done, lkey[0], compile_scoring,
                                                  self._world(lkey[0]), log_source))
        if self.warming:
            self.waiting.append((lkey, log_source))
            return
        for t in self._leaders(self.plan.by_log[lkey]):
            self._submit(self.task_done, t, execute, t, self._world(t.world), log_source,
                         self.plan.configs[t.algo], self.spec.noise, self.spec.vary,
                         self.plan.classes[t.algo])

    def _leaders(self, tasks: list[Task]) -> list[Task]:
        """The tasks of one log that run: a deterministic algorithm's first task per draw; its
        other tasks there wait in `followers` for that task's row."""
        leaders, first = [], {}
        for t in tasks:
            if self.plan.classes[t.algo].deterministic:
                same = (t.world, t.algo, t.log_seed, t.draw)
                if same in first:
                    self.followers.setdefault(first[same].key, []).append(t)
                    continue
                first[same] = t
            leaders.append(t)
        return leaders

    def _fail_tasks(self, lkey: tuple[str, int], problem: str) -> None:
        self.bar.note(f"{lkey[0]} seed {lkey[1]}: {problem}")
        for t in self.plan.by_log[lkey]:
            row = new_row(t, self.spec.noise, self.spec.vary)
            row.update(status="failed", error=problem, map_file=None, finished_at=_now())
            self.store.add(row)
            self.outcome.failed += 1
            self.bar.advance(t.label + f" ({problem[:50]})", False)
            self._stored(row)

    def _world(self, key: str):
        if key not in self.shared:
            info = self.plan.infos[key]
            self.shared[key] = self.ex.scatter(info) if self.remote else info
        return self.shared[key]

    def compile_done(self, fut, algo: str) -> None:
        """One compile job ended; once all have, the waiting logs' tasks go out."""
        self.warming.discard(fut)
        if not self.warming:
            waiting, self.waiting = self.waiting, []
            for lkey, log_source in waiting:
                self._send_tasks(lkey, log_source)

    def task_done(self, fut, task: Task) -> None:
        """A SLAM task ended: store its arrays and row (results.json rewritten at once)."""
        row, arrays = self.ex.result(fut)
        row["map_file"] = save_arrays(self.plan.out_dir, task, arrays)
        row["finished_at"] = _now()
        self._finished(task, row)
        for f in self.followers.pop(task.key, []):
            self._finished(f, dict(row, repeat=int(f.repeat), slam_seed=int(f.slam_seed),
                                   same_as=int(task.repeat)))

    def _finished(self, task: Task, row: dict) -> None:
        """Store the row of `task` and count it."""
        self.store.add(row)
        ok = row["status"] == "ok"
        self.outcome.ok += ok
        self.outcome.failed += not ok
        self.bar.advance(task.label + ("" if ok else f" ({str(row['error'])[:50]})"), ok)
        self._stored(row)

    def _stored(self, row: dict) -> None:
        if self.on_row is not None and self.on_row(row):
            raise _StopRun


class _StopRun(Exception):
    """on_row asked the run to stop."""


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
