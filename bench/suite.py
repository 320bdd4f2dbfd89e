"""Suites: a named list of worlds, each recorded with several noise draws (`bench run --suite`).

A suite file is YAML:

    name: general                    # optional, default: the file's stem
    description: ...                 # optional
    draws: 3                         # noise draws per world (optional, default 3)
    lidar: [lds-01, utm-30lx]        # optional: record with these lidars (sim/lidars/ names or
                                     #   YAML files, relative to the suite file), each world
                                     #   crossed with each; default the LDS-01
    worlds:
      - rectangle_s                  # a shipped world
      - ../my_worlds/office.yaml     # a world file, relative to the suite file
      - {generate: office, seed: 0}  # a generated world (python -m worlds generate)
      - {generate: hall, seed: 1, size: [9, 7]}

Shipped suites live in bench/suites/ and are named without the extension. Generated worlds
are written once to the log cache's `generated/` folder (keyed by the generator's code, so
an edited generator writes new files) and run from there like any world file.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bench.plan import MAX_DRAWS
from worlds.paths import check_name, names_a_file
from worlds.yamlio import InputError, _suggest, atomic_write_text, check_keys, load_yaml, short

__all__ = ["Suite", "load_suite", "list_suites", "suite_dir", "DEFAULT_DRAWS"]

DEFAULT_DRAWS = 3
_KEYS = ["name", "description", "draws", "worlds", "lidar"]
# a suite of the limits runs for weeks; they keep a file of a few bytes from planning millions
# of tasks (docs/formats.md, "Limits")
MAX_WORLDS = 1000
_GENERATE_KEYS = ["generate", "seed", "size"]


@dataclass(frozen=True)
class Suite:
    """name; description; draws >= 1; worlds: shipped names or absolute YAML paths; lidars:
    catalogue names or absolute lidar YAML paths (empty: the default lidar)."""

    name: str
    description: str
    draws: int
    worlds: tuple[str, ...]
    source: str = ""
    lidars: tuple[str, ...] = ()


def suite_dir() -> Path:
    """The folder of the shipped suites."""
    return Path(__file__).resolve().parent / "suites"


def list_suites() -> list[str]:
    """Names of the shipped suites, sorted."""
    return sorted(p.stem for p in suite_dir().glob("*.yaml"))


def load_suite(name_or_path: str) -> Suite:
    """A shipped suite by name ('general') or a suite YAML file; InputError naming the file
    and the field for anything wrong, including a world that does not exist."""
    s = str(name_or_path)
    p = Path(s).expanduser()
    if not names_a_file(s):
        p = suite_dir() / f"{s}.yaml"
        if not p.is_file():
            raise InputError(f"--suite {s}: no such suite (shipped: {', '.join(list_suites())}; "
                             "or give a path to a suite .yaml file)")
    elif not p.is_file():
        raise InputError(f"--suite {s}: file not found")
    where = str(p) if p.parent != suite_dir() else p.name
    data = load_yaml(p)
    if not isinstance(data, dict):
        raise InputError(f"{where}: top level: expected a mapping with keys {', '.join(_KEYS)}")
    check_keys(data, _KEYS, where)
    if "name" in data:
        name = check_name(data["name"], where, "name")
    else:
        name = check_name(p.stem, where, "name (missing; the file's name stands in)")
    desc = "" if data.get("description") is None else data["description"]
    if not isinstance(desc, str):
        raise InputError(f"{where}: description: expected a string, got {short(desc)}")
    draws = data.get("draws", DEFAULT_DRAWS)
    if isinstance(draws, bool) or not isinstance(draws, int) or not 1 <= draws <= MAX_DRAWS:
        raise InputError(f"{where}: draws: expected an integer from 1 to {MAX_DRAWS}, "
                         f"got {short(draws)}")
    items = data.get("worlds")
    if not isinstance(items, list) or not items:
        raise InputError(f"{where}: worlds: expected a non-empty list of worlds")
    if len(items) > MAX_WORLDS:
        raise InputError(f"{where}: worlds: {len(items):,} worlds, more than the limit of "
                         f"{MAX_WORLDS}")
    # every entry is checked before any world is generated (minutes each)
    generated = {i: _generated_args(item, where, f"worlds[{i}]")
                 for i, item in enumerate(items) if isinstance(item, dict)}
    refs = [None if i in generated else _world(item, where, f"worlds[{i}]", p.parent)
            for i, item in enumerate(items)]
    worlds = []
    for i, ref in enumerate(refs):
        w = ref if ref is not None else _generate(*generated[i], where, f"worlds[{i}]")
        if w not in worlds:
            worlds.append(w)
    return Suite(name, desc, draws, tuple(worlds), str(p), _lidars(data.get("lidar"), where, p.parent))


def _lidars(value: Any, where: str, base: Path) -> tuple[str, ...]:
    """The suite's `lidar` field -> catalogue names and absolute YAML paths (each checked)."""
    from sim.lidar import load_lidar
    if value is None:
        return ()
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not items or len(items) > 100:
        raise InputError(f"{where}: lidar: expected a lidar name, a .yaml path or a list of "
                         f"up to 100 of them, got {short(value)}")
    out = []
    for i, item in enumerate(items):
        field = "lidar" if isinstance(value, str) else f"lidar[{i}]"
        if not isinstance(item, str) or not item.strip():
            raise InputError(f"{where}: {field}: expected a lidar name or a .yaml path, got {short(item)}")
        item = item.strip()
        if names_a_file(item):
            item = str((base / Path(item).expanduser()).resolve())
        else:
            check_name(item, where, field)
        try:
            load_lidar(item)
        except InputError as err:
            raise InputError(f"{where}: {field}: {err}") from None
        if item not in out:
            out.append(item)
    return tuple(out)


def _world(item: Any, where: str, field: str, base: Path) -> str:
    """One entry of `worlds` -> a shipped world name or an absolute YAML path (checked)."""
    from worlds.load import list_worlds, load_world
    if not isinstance(item, str) or not item.strip():
        raise InputError(f"{where}: {field}: expected a world name, a .yaml path or "
                         f"{{generate: KIND, seed: S}}, got {short(item)}")
    item = item.strip()
    if names_a_file(item):
        p = (base / Path(item).expanduser()).resolve()
        if not p.is_file():
            raise InputError(f"{where}: {field}: world file {p} not found")
        ref = str(p)
    else:
        if item not in list_worlds():
            raise InputError(f"{where}: {field}: no such world '{item}'"
                             f"{_suggest(item, list_worlds())}")
        ref = item
    try:
        load_world(ref)
    except InputError as err:
        raise InputError(f"{where}: {field}: {err}") from None
    return ref


def _generator_key() -> str:
    """Digest of the code that decides a generated world's bytes (generator, layouts, route
    planner)."""
    import worlds.generate
    import worlds.layouts
    import worlds.route
    h = hashlib.sha256()
    for mod in (worlds.generate, worlds.layouts, worlds.route):
        h.update(Path(mod.__file__).read_bytes())
    return h.hexdigest()[:12]


def _generated_args(item: dict, where: str, field: str) -> tuple[str, int, tuple | None]:
    """The checked (kind, seed, size) of a {generate, seed, size} entry, nothing drawn yet."""
    from worlds.generate import KINDS, check_args
    check_keys(item, _GENERATE_KEYS, where, field)
    if "generate" not in item:
        raise InputError(f"{where}: {field}.generate: missing (the kind of world to generate)")
    seed = item.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"{where}: {field}.seed: expected an integer >= 0, got {short(seed)}")
    size = item.get("size")
    if size is not None:
        if (not isinstance(size, list) or len(size) != 2
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in size)):
            raise InputError(f"{where}: {field}.size: expected [width, height] in m, got {short(size)}")
        size = (float(size[0]), float(size[1]))
    kind = item["generate"]
    if kind not in KINDS:
        raise InputError(f"{where}: {field}.generate: unknown kind {short(kind)}"
                         f"{_suggest(str(kind), list(KINDS))}")
    try:
        check_args(kind, seed, size)
    except InputError as err:
        raise InputError(f"{where}: {field}: {err}") from None
    return kind, seed, size


def _generate(kind: str, seed: int, size: tuple | None, where: str, field: str) -> str:
    """Write (once) the world a checked generate entry stands for; its YAML path."""
    from worlds.generate import generate_yaml
    from bench.cache import cache_dir
    key = hashlib.sha256(f"{kind}|{seed}|{size}|{_generator_key()}".encode()).hexdigest()[:16]
    out = cache_dir() / "generated" / f"{kind}-s{seed}-{key}.yaml"
    if not out.is_file():
        try:
            text = generate_yaml(str(kind), seed, size)
        except InputError as err:
            raise InputError(f"{where}: {field}: {err}") from None
        out.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out, text)
    return str(out)
