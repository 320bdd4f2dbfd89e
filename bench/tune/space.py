"""Search spaces of `bench tune`: which config fields a tune may change, and over what values.

A space is YAML, one entry per dotted config field of the algorithm (`python -m slam fields
ALGO` lists them):

    algo: graph                                  # optional: the algorithm it is written for
    params:
      trajectory_builder.motion_filter.max_distance_meters: {low: 0.05, high: 0.4}
      pose_graph.constraint_builder.min_score: {low: 0.5, high: 0.8, step: 0.01}
      trajectory_builder.ceres_scan_matcher.translation_weight: {low: 1, high: 1000, log: true}
      pose_graph.optimize_every_n_nodes: {low: 20, high: 180}      # an int field: integers
      trajectory_builder.submaps.grid_type: {choices: [tsdf, probability_grid]}

A range's type follows the field's: an int field draws integers, a float field numbers. Every
value a space can draw is checked against the config dataclass before a trial runs. Shipped
spaces (bench/tune/spaces/ALGO.yaml) hold the fields that matter most for each algorithm.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from worlds.yamlio import InputError, _suggest, check_keys, load_yaml, set_dotted, short

__all__ = ["Param", "SearchSpace", "load_space", "default_space_path", "overrides_of",
           "field_defaults", "MAX_PARAMS"]

MAX_PARAMS = 100
_SPACE_KEYS = ["algo", "params"]
_RANGE_KEYS = ["low", "high", "log", "step"]


@dataclass(frozen=True)
class Param:
    """One searched field: its dotted path and either a range (low, high, log scale, step;
    integer when the field is) or a list of choices."""

    path: str
    kind: str                   # "float", "int" or "choice"
    low: float | int | None = None
    high: float | int | None = None
    log: bool = False
    step: float | int | None = None
    choices: tuple = ()

    def suggest(self, trial) -> Any:
        """The value an Optuna trial draws for this field."""
        if self.kind == "choice":
            return trial.suggest_categorical(self.path, list(self.choices))
        if self.kind == "int":
            return trial.suggest_int(self.path, int(self.low), int(self.high), log=self.log,
                                     step=int(self.step or 1))
        return trial.suggest_float(self.path, float(self.low), float(self.high), log=self.log,
                                   step=self.step)


@dataclass(frozen=True)
class SearchSpace:
    """The fields a tune of `algo` searches, in the file's order; `source` names the file."""

    algo: str
    params: tuple[Param, ...]
    source: str = ""

    def suggest(self, trial) -> dict[str, Any]:
        """{dotted field: value} drawn by an Optuna trial."""
        return {p.path: p.suggest(trial) for p in self.params}

    def defaults(self) -> dict[str, Any] | None:
        """{dotted field: class default} when every default lies in the space, else None."""
        fields = field_defaults(self.algo)
        out = {}
        for p in self.params:
            v = fields[p.path]
            inside = (v in p.choices if p.kind == "choice" else
                      p.low <= v <= p.high and (p.step is None or
                                                abs((v - p.low) / p.step - round((v - p.low) / p.step)) < 1e-9))
            if not inside:
                return None
            out[p.path] = v
        return out


def default_space_path(algo: str) -> Path:
    """The shipped space of `algo` (it may not exist: then --space is required)."""
    return Path(__file__).resolve().parent / "spaces" / f"{algo}.yaml"


def overrides_of(values: dict[str, Any]) -> dict:
    """{dotted field: value} -> the nested mapping a config file (and bench's --set) holds."""
    out: dict = {}
    for path, value in values.items():
        set_dotted(out, path, value)
    return out


def load_space(path: str | Path | None, algo: str) -> SearchSpace:
    """The search space at `path` (None: the shipped space of `algo`), every field checked
    against the config of `algo`; InputError naming the file and the field otherwise."""
    if path is None:
        path = default_space_path(algo)
        if not path.is_file():
            raise InputError(f"--space: {algo} has no shipped search space; write one "
                             "(docs/benchmark.md, 'Tuning')")
    path = Path(path)
    where = str(path)
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(f"{where}: top level: expected a mapping with 'params', got {short(data)}")
    check_keys(data, _SPACE_KEYS, where)
    if data.get("algo") not in (None, algo):
        raise InputError(f"{where}: algo: the space is written for {short(data['algo'])}, "
                         f"the tune is of {algo}")
    params = data.get("params")
    if not isinstance(params, dict) or not params:
        raise InputError(f"{where}: params: expected a mapping of config fields to ranges, got "
                         f"{short(params)}")
    if len(params) > MAX_PARAMS:
        raise InputError(f"{where}: params: {len(params)} fields; at most {MAX_PARAMS}")
    fields = field_defaults(algo)
    out = tuple(_param(where, str(name), spec, fields, algo) for name, spec in params.items())
    return SearchSpace(algo, out, where)


def field_defaults(algo: str) -> dict[str, Any]:
    """Dotted field -> default of every leaf field of `algo`'s config."""
    from slam import registry
    from slam.fields import config_fields
    return {f.path: f.default for f in config_fields(registry.get(algo).config_class)}


def _param(where: str, name: str, spec: Any, fields: dict[str, Any], algo: str) -> Param:
    at = f"{where}: params.{name}"
    if name not in fields:
        raise InputError(f"{at}: not a config field of {algo}{_suggest(name, sorted(fields))}")
    default = fields[name]
    if not isinstance(spec, dict):
        raise InputError(f"{at}: expected {{low: , high: }} or {{choices: [...]}}, got {short(spec)}")
    if "choices" in spec:
        if set(spec) != {"choices"}:
            raise InputError(f"{at}: choices go alone, without {', '.join(sorted(set(spec) - {'choices'}))}")
        choices = spec["choices"]
        if not isinstance(choices, list) or not choices:
            raise InputError(f"{at}.choices: expected a non-empty list, got {short(choices)}")
        for c in choices:
            if not isinstance(c, (bool, int, float, str)) or c is None:
                raise InputError(f"{at}.choices: expected numbers, strings or booleans, got {short(c)}")
            _check_value(where, name, c, algo)
        return Param(name, "choice", choices=tuple(choices))
    check_keys(spec, _RANGE_KEYS + ["choices"], where, f"params.{name}")
    if isinstance(default, bool) or not isinstance(default, (int, float)):
        raise InputError(f"{at}: the field holds {short(default)}, not a number; give "
                         "{choices: [...]}")
    kind = "int" if isinstance(default, int) else "float"
    for key in ("low", "high"):
        if key not in spec:
            raise InputError(f"{at}.{key}: missing")
        v = spec[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"{at}.{key}: expected a number, got {short(v)}")
        if kind == "int" and not float(v).is_integer():
            raise InputError(f"{at}.{key}: the field is an integer, got {short(v)}")
    low, high = spec["low"], spec["high"]
    if not low < high:
        raise InputError(f"{at}: low ({low}) must be below high ({high})")
    log = spec.get("log", False)
    if not isinstance(log, bool):
        raise InputError(f"{at}.log: expected true or false, got {short(log)}")
    if log and low <= 0:
        raise InputError(f"{at}: a log-scale range needs low > 0, got {low}")
    step = spec.get("step")
    if step is not None:
        if isinstance(step, bool) or not isinstance(step, (int, float)) or not step > 0:
            raise InputError(f"{at}.step: expected a number > 0, got {short(step)}")
        if log:
            raise InputError(f"{at}: give step or log, not both")
        if kind == "int" and not float(step).is_integer():
            raise InputError(f"{at}.step: the field is an integer, got {short(step)}")
    if kind == "int":
        low, high, step = int(low), int(high), (int(step) if step is not None else None)
    else:
        low, high, step = float(low), float(high), (float(step) if step is not None else None)
    for v in (low, high):
        _check_value(where, name, v, algo)
    return Param(name, kind, low, high, log, step)


def _check_value(where: str, name: str, value: Any, algo: str) -> None:
    """InputError when the config of `algo` refuses `value` for the field `name`."""
    from bench.plan import load_config_checked
    try:
        load_config_checked(algo, None, overrides_of({name: value}))
    except InputError as err:
        raise InputError(f"{where}: params.{name}: {short(value)} is refused: "
                         f"{str(err).split(': ', 2)[-1]}") from None

