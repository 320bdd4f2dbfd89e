"""The algorithm registry: names -> Slam classes, for `slam` and `bench` alike.

The built-in algorithms are named here by module path (imported on first use); third-party
ones come from the `slam_bench.algorithms` entry-point group (a class, or a module that calls
`register` on import) or from `register` in the caller's own code.
"""
from __future__ import annotations

import importlib
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Callable, Mapping

from worlds.paths import check_name
from worlds.yamlio import InputError, from_dict, load_yaml, short
from slam.base import check_algorithm_class

__all__ = ["ENTRY_POINT_GROUP", "BUILTIN", "register", "algorithms", "names", "get", "find",
           "ensure", "load_config", "explain_config", "load_plugins"]

ENTRY_POINT_GROUP = "slam_bench.algorithms"
# name -> "module:Class"; the benchmark's tables list them in this order
BUILTIN = {"pf": "slam.pf:ParticleFilterSlam", "gn": "slam.gn:GaussNewtonSlam",
           "graph": "slam.graph:GraphSlam", "oracle": "slam.oracle:OracleSlam"}

_REGISTERED: dict[str, type] = {}
_plugins_loaded = False


def register(name: str) -> Callable[[type], type]:
    """Class decorator: make a Slam subclass available as `name` (checked against the contract;
    the name becomes part of result paths, so it follows the name rule of worlds.paths)."""
    check_name(name, f"algorithm {short(name)}", "name")

    def deco(cls: type) -> type:
        check_algorithm_class(cls, name)
        cls.name = name
        _REGISTERED[name] = cls
        return cls
    return deco


def _load_builtins() -> None:
    for name, target in BUILTIN.items():
        if name not in _REGISTERED:
            module, cls_name = target.split(":")
            register(name)(getattr(importlib.import_module(module), cls_name))


def load_plugins() -> list[str]:
    """Register every `slam_bench.algorithms` entry point; their names. A plugin that fails to
    load or breaks the contract raises InputError naming it."""
    global _plugins_loaded
    loaded = []
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            obj = ep.load()
            if isinstance(obj, type) and ep.name not in _REGISTERED:
                register(ep.name)(obj)
        except Exception as err:
            raise InputError(f"algorithm plugin '{ep.name}' ({ep.value}) failed to load: {err}") from None
        loaded.append(ep.name)
    _plugins_loaded = True
    return loaded


def algorithms() -> dict[str, type]:
    """Every known algorithm, built-ins first, then the rest by name."""
    _load_builtins()
    if not _plugins_loaded:
        load_plugins()
    order = [n for n in BUILTIN if n in _REGISTERED] + sorted(set(_REGISTERED) - set(BUILTIN))
    return {n: _REGISTERED[n] for n in order}


def names() -> list[str]:
    """Names of every known algorithm (see algorithms())."""
    return list(algorithms())


def get(name: str) -> type:
    """The class registered as `name`; InputError naming the known ones otherwise."""
    known = algorithms()
    if name not in known:
        raise InputError(f"unknown algorithm '{name}' (known: {', '.join(known)})")
    return known[name]


def find(name: str) -> type | None:
    """The class registered as `name`, or None (a map scored from elsewhere, an algorithm not
    installed in this environment): for readers of stored rows, which may name either."""
    return algorithms().get(name)


def ensure(name: str, cls: type | None) -> None:
    """Register `cls` as `name` unless the name is known here (a worker process that was sent
    the class of an algorithm its parent registered in code)."""
    if cls is not None and name not in algorithms():
        register(name)(cls)


def load_config(name: str, config: Any = None, log=None):
    """The config dataclass of algorithm `name` from None (defaults), a mapping or a YAML path.

    With `log` (a SensorLog), the values the algorithm derives from the log's sensors
    (Slam.derive_config) stand in for the class defaults, and what `config` names is set over
    them: a value set in a config still wins. A config dataclass is taken as it is.
    """
    return _resolve(name, config, log)[0]


def explain_config(name: str, config: Any = None, log=None) -> list:
    """The values algorithm `name` derives from `log` (slam.sensors.Derived), each marked
    `overridden` when `config` sets its path: [(Derived, overridden), ...]."""
    return _resolve(name, config, log)[1]


def _resolve(name: str, config: Any, log):
    algo = get(name)
    cls = algo.config_class
    if isinstance(config, cls):
        return config, []
    if config is None:
        data, where = {}, "<config>"
    elif isinstance(config, Mapping):
        data, where = config, "<config>"
    else:
        path = Path(config)
        data, where = load_yaml(path), str(path)
    base, derived = cls(), []
    if log is not None:
        from slam.sensors import apply_derived, sensor_facts
        derived = list(algo.derive_config(sensor_facts(log)))
        base = apply_derived(base, derived)
    cfg = from_dict(cls, data, where=where, base=base)
    return cfg, [(d, _names(data, d.path)) for d in derived]


def _names(data: Any, path: str) -> bool:
    """True when the nested mapping `data` sets the dotted `path`."""
    for part in path.split("."):
        if not isinstance(data, Mapping) or part not in data:
            return False
        data = data[part]
    return True
