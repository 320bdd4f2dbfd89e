"""What a benchmark run does: the run spec (worlds x algorithms x repeats), its seeds and tasks.

The reference study recorded one sensor log per world and ran each SLAM 10 times on it with
different seeds (`vary="slam"`, the default). `vary="data"` re-records the log with a new
sensor seed each repeat (same SLAM seed); `vary="both"` changes both.

Seeds, for base seed S and repeat r (0-based):
  vary=slam: log seed S,     slam seed S + r
  vary=data: log seed S + r, slam seed S
  vary=both: log seed S + r, slam seed S + r
With `draws` D > 1 (suites: each world recorded D times with other noise), draw d has log
seed S + d and `repeats` R runs with slam seeds S .. S + R - 1 (vary must be "slam"); its
rows are numbered d * R + r and carry `draw` = d.
"""
from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from worlds.paths import check_name, is_name, names_a_file
from worlds.yamlio import InputError, set_override, short, to_dict
from slam.registry import ENTRY_POINT_GROUP

__all__ = ["RunSpec", "Task", "VARY", "parse_worlds", "resolve_algos", "shipped_algos",
           "load_plugins", "parse_configs", "user_config", "parse_overrides", "read_log_set", "seeds_for",
           "make_tasks", "shard_tasks", "parse_shard", "ENTRY_POINT_GROUP"]

VARY = ("slam", "data", "both")


# a run of the limits takes years; they keep a file of a few bytes from planning 10^15 tasks
MAX_REPEATS = 10_000
MAX_DRAWS = 1_000
MAX_LIDARS = 100


def _check_count(value, flag: str, limit: int) -> None:
    """InputError unless `value` is an integer from 1 to `limit`."""
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= limit:
        raise InputError(f"{flag} must be an integer from 1 to {limit:,}, got {short(value)}")


@dataclass(frozen=True)
class RunSpec:
    """The arguments that decide a run's rows (not how fast they are computed).

    worlds: world names or YAML paths; algos: registered algorithm names; repeats >= 1;
    noise: sensor-noise profile name or YAML path; seed: base seed; vary: slam|data|both;
    configs: algo -> config YAML path (absent: the algorithm's defaults); draws >= 1: noise
    draws per world (module docstring); min_coverage: a log whose lidar saw less of the true
    walls gives failed rows; suite: the suite's name, for the report ("" outside a suite);
    logs: recorded sensor logs to run on instead of recording (absolute paths; see
    read_log_set); overrides: algo -> nested mapping of config fields set on top of its config;
    shard: (K, N), this run does the K-th of N deterministic slices of the tasks (shard_tasks);
    lidars: catalogue names or lidar YAML paths the logs are recorded with, each world crossed
    with each (world key WORLD+LIDAR; empty: the recording's default, the LDS-01).
    """

    worlds: tuple[str, ...]
    algos: tuple[str, ...]
    repeats: int = 10
    noise: str = "realistic"
    seed: int = 0
    vary: str = "slam"
    configs: dict = field(default_factory=dict)
    draws: int = 1
    min_coverage: float = 0.95
    suite: str = ""
    logs: tuple[str, ...] = ()
    overrides: dict = field(default_factory=dict)
    shard: tuple[int, int] = (1, 1)
    lidars: tuple[str, ...] = ()

    def __post_init__(self):
        _check_count(self.repeats, "--repeats", MAX_REPEATS)
        if self.vary not in VARY:
            raise InputError(f"--vary must be one of {', '.join(VARY)}, got {short(self.vary)}")
        _check_count(self.draws, "--draws", MAX_DRAWS)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or not 0 <= self.seed < 2**62:
            raise InputError(f"--seed must be an integer from 0 to 2^62, got {short(self.seed)}")
        for name, value in (("--world", self.worlds), ("--algo", self.algos), ("--logs", self.logs)):
            if isinstance(value, str) or not isinstance(value, (list, tuple)) or not all(
                    isinstance(v, str) and v for v in value):
                raise InputError(f"{name} must be a list of names, got {short(value)}")
        for a in self.algos:
            check_name(a, "--algo", "algorithm")
        if not isinstance(self.noise, str) or not self.noise:
            raise InputError(f"--noise must be a profile name or a YAML file, got {short(self.noise)}")
        if not isinstance(self.suite, str) or (self.suite and not is_name(self.suite)):
            check_name(self.suite, "--suite", "name")
        for name, value in (("--config", self.configs), ("--set", self.overrides)):
            if not isinstance(value, dict) or not all(k in self.algos for k in value):
                raise InputError(f"{name} must map the run's algorithms, got {short(value)}")
        if not all(isinstance(v, str) for v in self.configs.values()):
            raise InputError(f"--config must name YAML files, got {short(self.configs)}")
        if self.draws > 1 and self.vary != "slam":
            raise InputError(f"--vary {self.vary}: with --draws the noise changes per draw; "
                             "repeats within a draw vary the SLAM seed only")
        if isinstance(self.min_coverage, bool) or not isinstance(self.min_coverage, (int, float)) \
                or not 0.0 <= self.min_coverage <= 1.0:
            raise InputError(f"--min-coverage must be a share in [0, 1], got {short(self.min_coverage)}")
        if not self.worlds:
            raise InputError("no world given")
        if not self.algos:
            raise InputError("no algorithm given")
        object.__setattr__(self, "worlds", tuple(self.worlds))
        object.__setattr__(self, "algos", tuple(self.algos))
        object.__setattr__(self, "configs", dict(self.configs))
        object.__setattr__(self, "logs", tuple(self.logs))
        object.__setattr__(self, "overrides", dict(self.overrides))
        if not isinstance(self.shard, (list, tuple)):
            raise InputError(f"--shard must be K/N with 1 <= K <= N, got {short(self.shard)}")
        shard = tuple(self.shard)
        if (len(shard) != 2 or not all(isinstance(v, int) and not isinstance(v, bool) for v in shard)
                or not 1 <= shard[0] <= shard[1]):
            raise InputError(f"--shard must be K/N with 1 <= K <= N, got {short(self.shard)}")
        object.__setattr__(self, "shard", shard)
        if isinstance(self.lidars, str) or not isinstance(self.lidars, (list, tuple)) or not all(
                isinstance(v, str) and v for v in self.lidars):
            raise InputError(f"--lidar must be a list of lidar names or files, got {short(self.lidars)}")
        if len(self.lidars) > MAX_LIDARS:
            raise InputError(f"--lidar: {len(self.lidars)} lidars, more than the limit of {MAX_LIDARS}")
        object.__setattr__(self, "lidars", tuple(dict.fromkeys(self.lidars)))
        if self.lidars and self.logs:
            raise InputError("--lidar: a run on given --logs takes their lidar; record instead")
        if self.logs and (self.draws != 1 or self.vary != "slam"):
            raise InputError("--logs: each log is one draw; repeats vary the SLAM seed only")

    def to_json(self) -> dict:
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v)
                for f in dataclasses.fields(self)}

    @classmethod
    def from_json(cls, data: dict) -> "RunSpec":
        return cls(**{f.name: data[f.name] for f in dataclasses.fields(cls) if f.name in data})


@dataclass(frozen=True)
class Task:
    """One SLAM run: `algo` on world `world` (key of the world table), repeat `repeat`."""

    world: str
    algo: str
    repeat: int
    log_seed: int
    slam_seed: int
    draw: int = 0

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.world, self.algo, self.repeat)

    @property
    def label(self) -> str:
        return f"{self.world}/{self.algo}/{self.repeat}"


def shard_tasks(tasks: list[Task], shard: tuple[int, int]) -> list[Task]:
    """The K-th of N slices of `tasks` (every N-th task from the (K-1)-th): the same slice
    for the same spec, on any machine, and the N slices together hold every task once."""
    k, n = shard
    return tasks[k - 1::n]


def parse_shard(text: str) -> tuple[int, int]:
    """'K/N' -> (K, N), 1 <= K <= N."""
    m = re.fullmatch(r"\s*(\d+)\s*/\s*(\d+)\s*", str(text))
    if not m or not 1 <= int(m[1]) <= int(m[2]):
        raise InputError(f"--shard: expected K/N with 1 <= K <= N (e.g. 3/8), got {text!r}")
    return int(m[1]), int(m[2])


def seeds_for(vary: str, seed: int, repeat: int) -> tuple[int, int]:
    """(log seed, slam seed) of repeat `repeat` (see the module docstring)."""
    if vary == "slam":
        return seed, seed + repeat
    if vary == "data":
        return seed + repeat, seed
    if vary == "both":
        return seed + repeat, seed + repeat
    raise InputError(f"--vary must be one of {', '.join(VARY)}, got {vary!r}")


def make_tasks(spec: RunSpec, world_keys: list[str] | None = None,
               log_seeds: list[tuple[str, int]] | None = None) -> list[Task]:
    """All tasks of `spec`, repeat-major so early rows cover every world and algorithm.

    world_keys: the keys under which each world of spec.worlds is stored (default: as given);
    log_seeds: with spec.logs, (world key, log seed) of each log: the k-th log of a world is
    its draw k.
    """
    keys = list(world_keys) if world_keys is not None else list(spec.worlds)
    tasks = []
    if spec.logs:
        draws: dict[str, int] = {}
        per_log = []
        for w, seed in log_seeds:
            per_log.append((w, seed, draws.get(w, 0)))
            draws[w] = draws.get(w, 0) + 1
        for r in range(spec.repeats):
            for w, seed, d in per_log:
                for a in spec.algos:
                    tasks.append(Task(w, a, d * spec.repeats + r, seed, spec.seed + r, d))
        return tasks
    for d in range(spec.draws):
        for r in range(spec.repeats):
            log_seed, slam_seed = seeds_for(spec.vary, spec.seed, r)
            if spec.draws > 1:
                log_seed = spec.seed + d
            for w in keys:
                for a in spec.algos:
                    tasks.append(Task(w, a, d * spec.repeats + r, log_seed, slam_seed, d))
    return tasks


def parse_worlds(text: str) -> list[str]:
    """'all' | 'NAME|FILE[,NAME|FILE...]' -> world names and absolute YAML paths (not loaded)."""
    if text is None or not str(text).strip():
        raise InputError("--world is empty")
    items = [t.strip() for t in str(text).split(",") if t.strip()]
    if items == ["all"]:
        import worlds
        names = list(worlds.list_worlds())
        if not names:
            raise InputError("--world all: no worlds are installed")
        return names
    seen = []
    for it in items:
        p = Path(it).expanduser()
        if names_a_file(it):
            it = str(p.resolve())  # absolute, so --resume works from any folder
        if it not in seen:
            seen.append(it)
    return seen


def load_plugins() -> list[str]:
    """The built-in algorithms and every `slam_bench.algorithms` entry point (slam.registry);
    returns the names of the entry points loaded."""
    from slam import registry
    registry.algorithms()
    return registry.load_plugins()


def shipped_algos() -> list[str]:
    """The algorithms shipped in this tree (slam.registry.BUILTIN), in the registry's order."""
    from slam import registry
    return list(registry.BUILTIN)


def resolve_algos(text: str | None) -> list[str]:
    """'pf,gn' -> checked names; None/'all' -> every registered algorithm (built-ins first);
    an empty text is an InputError."""
    from slam import registry
    order = registry.names()
    if text is None or str(text).strip() == "all":
        if not order:
            raise InputError("no SLAM algorithm is registered")
        return order
    names = []
    for a in str(text).split(","):
        a = a.strip()
        if not a:
            continue
        if a not in order:
            raise InputError(f"unknown algorithm '{a}' (known: {', '.join(order) or 'none'})")
        if a not in names:
            names.append(a)
    if not names:
        raise InputError("--algo is empty")
    return names


def parse_configs(items: list[str] | None, algos: list[str]) -> dict[str, str]:
    """['pf=pf.yaml', ...] -> {'pf': 'pf.yaml'}, each file checked against the algorithm's config."""
    out: dict[str, str] = {}
    for item in items or []:
        if "=" not in item:
            raise InputError(f"--config expects ALGO=YAML, got '{item}'")
        algo, path = item.split("=", 1)
        algo = algo.strip()
        if algo not in algos:
            raise InputError(f"--config {item}: algorithm '{algo}' is not in this run "
                             f"({', '.join(algos)})")
        p = Path(path).expanduser()
        if not p.is_file():
            raise InputError(f"--config {item}: {p}: file not found")
        load_config_checked(algo, str(p.resolve()))
        out[algo] = str(p.resolve())
    return out


def load_config_checked(algo: str, path: str | None, overrides: dict | None = None) -> Any:
    """The config dataclass of `algo` from `path` (None: defaults) with `overrides` (a nested
    mapping) set on top; InputError on a bad file or field."""
    from slam.registry import load_config
    return load_config(algo, user_config(algo, path, overrides))


def user_config(algo: str, path: str | None, overrides: dict | None = None) -> dict:
    """What the user's config of `algo` sets: the YAML file's mapping (None: nothing) with
    `overrides` merged in, checked against the config class. The runs resolve it per log
    (slam.registry.load_config), over the values the algorithm derives from that log."""
    from slam.registry import load_config
    from worlds.yamlio import load_yaml
    data = load_yaml(Path(path)) if path else {}
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(f"{path}: top level: expected a mapping of config fields")
    load_config(algo, path)                 # errors name the file and the field
    merged = _merge(data, overrides) if overrides else dict(data)
    load_config(algo, merged)
    return merged


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def parse_overrides(items: list[str] | None, algos: list[str]) -> dict[str, dict]:
    """['pf.particles=50', 'graph.pose_graph.enable_loop_closure=false'] -> nested mappings per
    algorithm (values read as YAML scalars), each checked against the algorithm's config."""
    out: dict[str, dict] = {}
    for item in items or []:
        key, eq, value = item.partition("=")
        algo, dot, path = key.strip().partition(".")
        if not eq or not dot or not path:
            raise InputError(f"--set expects ALGO.FIELD=VALUE (e.g. pf.particles=50), got '{item}'")
        if algo not in algos:
            raise InputError(f"--set {item}: algorithm '{algo}' is not in this run ({', '.join(algos)})")
        try:
            set_override(out.setdefault(algo, {}), f"{path}={value}")
        except InputError as err:
            raise InputError(f"--set {short(item)}: {str(err).split(': ', 1)[-1]}") from None
    for algo, over in out.items():
        try:
            load_config_checked(algo, None, over)
        except InputError as err:
            raise InputError(f"--set: {algo}: {str(err).replace('<config>: ', '')}") from None
    return out


def read_log_set(text: str) -> list[tuple[str, str, int, str]]:
    """--logs DIR|FILE[,FILE...] -> (absolute log path, world reference, log seed, noise name)
    of every sensor log (.npz), sorted by path. The world is the log's own (meta world_source,
    else its shipped name world), so its true map can be made; InputError names the log when
    it is unreadable or its world cannot be found."""
    from sim.logs import read_log
    items = [Path(t.strip()).expanduser() for t in str(text or "").split(",") if t.strip()]
    if not items:
        raise InputError("--logs is empty")
    files = []
    for it in items:
        if it.is_dir():
            files += sorted(it.glob("*.npz"))
        elif it.is_file():
            files.append(it)
        else:
            raise InputError(f"--logs {it}: no such file or folder")
    if not files:
        raise InputError(f"--logs {text}: no .npz sensor log there")
    out, seen = [], {}
    for f in sorted({p.resolve() for p in files}):
        meta = read_log(f).meta
        world = _log_world(f, meta)
        seed = int(meta.get("seed", 0))
        key = (world, seed)
        if key in seen:
            raise InputError(f"--logs: {f} and {seen[key]} are both {world} with seed {seed}; "
                             "run them separately")
        seen[key] = f
        out.append((str(f), world, seed, str(meta.get("noise", {}).get("name", ""))))
    return out


def _log_world(path: Path, meta: dict) -> str:
    """The world of a recorded log as a loadable reference (a YAML path or a shipped name)."""
    from sim.logs import world_ref
    ref = world_ref(meta, path)
    if ref is None:
        name, src = meta.get("world") or "", meta.get("world_source") or ""
        where = (f"copy its YAML ({short(src)}) into the log's folder: a log's world is read "
                 "only from there or the shipped worlds" if src else "logs without a world "
                 "cannot be scored")
        raise InputError(f"{path}: meta.world: the log's world {short(name)} is not a shipped "
                         f"world and its YAML file is not in the log's folder; {where}")
    return ref


def config_dict(algo: str, path: str | None, overrides: dict | None = None) -> dict:
    """The config of `algo` over the class defaults as plain data (for run.json; each run
    derives its sensor-dependent values from its log on top of these defaults)."""
    return to_dict(load_config_checked(algo, path, overrides))

