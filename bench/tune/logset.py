"""Log sets: recorded logs with relation files, what `bench tune --objective relations` runs
its trials on (real logs have no true map and no true path, only relations).

A log set is YAML:

    name: csail                                     # optional, default: the file's stem
    description: ...                                # optional
    logs:
      - {log: data/csail.corrected.gfs, relations: data/mit-csail.relations}
      - {log: intel_s0.npz, relations: intel_s0.relations, name: intel_s0}

Paths are relative to the file. A log is a sensor log .npz or a CARMEN / GMapping log (what
`sim.logs.import_log` reads); its relations file holds `t1 t2 x y z roll pitch yaw`
lines on the log's clock (Kuemmerle et al. 2009). `name` (default: the log file's stem) names
the log's rows. A log set's run is a folder like a bench run's: results.json with one row per
log (world = the log's name), written as each finishes.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from worlds.paths import check_name
from worlds.yamlio import InputError, check_keys, load_yaml, short

__all__ = ["LogEntry", "LogSet", "load_logset", "run_logset", "relations_task", "MAX_LOGS"]

MAX_LOGS = 1000
_KEYS = ["name", "description", "logs"]
_ENTRY_KEYS = ["log", "relations", "name"]


@dataclass(frozen=True)
class LogEntry:
    """One log of a set: its name (the rows' world), the log file and its relations file."""

    name: str
    log: str
    relations: str


@dataclass(frozen=True)
class LogSet:
    """A named list of logs with relations; `source` is the file."""

    name: str
    description: str
    logs: tuple[LogEntry, ...]
    source: str = ""


def load_logset(path: str | Path) -> LogSet:
    """The log set in the YAML file `path`, every file checked to exist; InputError naming the
    file and the field otherwise."""
    p = Path(path)
    where = str(p)
    if not p.is_file():
        raise InputError(f"{where}: file not found (a log set: a YAML file listing logs and "
                         "their relations)")
    data = load_yaml(p)
    if not isinstance(data, dict):
        raise InputError(f"{where}: top level: expected a mapping with 'logs', got {short(data)}")
    check_keys(data, _KEYS, where)
    items = data.get("logs")
    if not isinstance(items, list) or not items:
        raise InputError(f"{where}: logs: expected a list of {{log: , relations: }}, got {short(items)}")
    if len(items) > MAX_LOGS:
        raise InputError(f"{where}: logs: {len(items)} logs; at most {MAX_LOGS}")
    entries, names = [], set()
    for i, item in enumerate(items):
        entry = _entry(where, p.parent, i, item)
        if entry.name in names:
            raise InputError(f"{where}: logs[{i}].name: '{entry.name}' again; give the logs "
                             "distinct names")
        names.add(entry.name)
        entries.append(entry)
    name = data.get("name", p.stem)
    check_name(str(name), f"{where}: name", "a log set's name")
    return LogSet(str(name), str(data.get("description", "")), tuple(entries), str(p.resolve()))


def _entry(where: str, base: Path, i: int, item: Any) -> LogEntry:
    at = f"{where}: logs[{i}]"
    if not isinstance(item, dict):
        raise InputError(f"{at}: expected {{log: FILE, relations: FILE}}, got {short(item)}")
    check_keys(item, _ENTRY_KEYS, where, f"logs[{i}]")
    files = {}
    for key in ("log", "relations"):
        if not isinstance(item.get(key), str) or not item[key]:
            raise InputError(f"{at}.{key}: expected a file name, got {short(item.get(key))}")
        f = (base / item[key]).resolve()
        if not f.is_file():
            raise InputError(f"{at}.{key}: {item[key]}: file not found")
        files[key] = str(f)
    name = item.get("name", Path(files["log"]).name.split(".")[0])
    check_name(str(name), f"{at}.name", "the log's name in rows")
    return LogEntry(str(name), files["log"], files["relations"])


def _read_any_log(path: str):
    from sim.logs import import_log, read_log
    return read_log(path) if path.endswith(".npz") else import_log(path)


def relations_task(algo: str, entry: LogEntry, config: dict, seed: int = 0) -> dict:
    """Run `algo` with `config` on one log and score it with its relations: a row (world = the
    log's name; relations_abs_trans_m the mean absolute translational error, the objective).
    A failing SLAM is a failed row, not a crash."""
    import time
    from metrics.relations import read_relations, relations_error
    from bench.task import failure_fields
    from slam.replay import run_algorithm
    row = {"world": entry.name, "algo": algo, "repeat": 0, "draw": 0, "status": "ok",
           "error": None, "slam_seed": seed, "log_file": entry.log}
    t0 = time.perf_counter()
    try:
        log = _read_any_log(entry.log)
        rel = read_relations(entry.relations)
        result = run_algorithm(algo, log, config=config, seed=seed)
        odom = (log.odom_t, log.odom_pose) if len(log.odom_t) else None
        res = relations_error(result.times, result.poses, rel, odom)
        if not res["n_used"]:
            raise ValueError("no relation has a pose at both ends (the relations' clock is "
                             "not the log's?)")
        row.update(relations_abs_trans_m=_finite(res["abs_trans_mean"]),
                   relations_abs_trans_std_m=_finite(res["abs_trans_std"]),
                   relations_abs_rot_deg=_finite(res["abs_rot_deg_mean"]),
                   relations_long_abs_trans_m=_finite(res["long"]["abs_trans_mean"]),
                   relations_used=res["n_used"])
    except Exception as err:  # a failing SLAM is a result of the trial
        row.update(failure_fields(err))
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def _finite(v) -> float | None:
    import math
    return float(v) if v is not None and math.isfinite(v) else None


def run_logset(algo: str, logset: LogSet, config: dict, folder: Path, jobs: int | None = None,
               scheduler: str | None = None, on_row=None) -> str:
    """Run `algo` with `config` on every log of `logset` not yet in `folder`'s results.json,
    the logs in parallel over the executor, each row stored as it finishes. on_row as in
    bench.runner.run_benchmark. Returns "complete", "stopped" or "interrupted"."""
    from bench.executors import make_executor
    from bench.results import ResultStore
    folder.mkdir(parents=True, exist_ok=True)
    store = ResultStore(folder)
    todo = [e for e in logset.logs if (e.name, algo, 0) not in store]
    if not todo:
        return "complete"
    ex = make_executor(jobs, scheduler)
    pending = {ex.submit(relations_task, algo, e, config, 0): e for e in todo}
    try:
        while pending:
            done, _ = ex.wait_any(list(pending))
            for fut in done:
                pending.pop(fut)
                row = ex.result(fut)
                store.add(row)
                if on_row is not None and on_row(row):
                    return "stopped"
    except KeyboardInterrupt:
        return "interrupted"
    finally:
        ex.shutdown(cancel=bool(pending))
    return "complete"
