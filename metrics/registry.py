"""The one list of metrics: what each computes, the keys it reports, how the benchmark's
tables show them and how far `bench regress` lets their means worsen.

score_map computes every metric of kind "map" (from a metrics.score.MapContext), the benchmark
also those of kind "trajectory" (from a metrics.trajectory.TrajectoryContext); keys of kind
"run" are written by the runner. summary.md, summary.csv and regress read `columns()`.
The built-in metrics are registered in metrics/builtin.py; third-party ones come from the
`slam_bench.metrics` entry-point group (a Metric, or a module that calls `register` on import),
loaded after the built-ins the first time the registry is read, or from `register` in the
caller's own code.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any, Callable

from worlds.yamlio import InputError

__all__ = ["KINDS", "ENTRY_POINT_GROUP", "Section", "Column", "Metric", "register", "unregister",
           "register_section", "load_plugins", "metrics", "sections", "columns", "compute",
           "compute_at_tolerance", "tolerances", "tolerance_key"]

ENTRY_POINT_GROUP = "slam_bench.metrics"
KINDS = ("map", "trajectory", "run")
# keys more than one metric may report (the last one computed wins)
_SHARED_KEYS = frozenset({"note"})


@dataclass(frozen=True)
class Section:
    """A table of summary.md: `name` (what columns refer to) and its heading."""

    name: str
    title: str


@dataclass(frozen=True)
class Column:
    """One reported key: a column of summary.csv and a cell of a summary.md table."""

    key: str
    label: str                              # heading of the key on its own
    decimals: int = 3                       # of mean and std in summary.md
    higher_is_better: bool | None = None    # None: neither (a count, a diagnostic)
    section: str = ""                       # a Section's name; "": the "More metrics" section
    short: str = ""                         # its label in a section of several keys ("P")
    tolerance: float | None = None          # regress: allowed worsening of the mean
    fallback: str = ""                      # a key shown instead in worlds whose rows lack
                                            # this one (the surface form -> the cell form)

    @property
    def worse(self) -> str:
        """The direction in which the mean gets worse: "drop" or "rise"."""
        return "drop" if self.higher_is_better else "rise"


@dataclass(frozen=True)
class Metric:
    """One metric family. compute(context) -> a metrics.result.Result (or None: not
    applicable); keys: what it reports; per_tolerance: keys the benchmark reports again at each
    grid tolerance k > 0 as KEY_tk; extra: skipped by score_map(..., gtfree=False)."""

    name: str
    kind: str
    keys: tuple[str, ...]
    columns: tuple[Column, ...]
    compute: Callable[[Any], Any] | None = None
    per_tolerance: tuple[str, ...] = ()
    extra: bool = False


_METRICS: dict[str, Metric] = {}
_SECTIONS: dict[str, Section] = {}
_plugins_loaded = False


def tolerance_key(key: str, tolerance: int) -> str:
    """The key under which the benchmark reports `key` at a grid tolerance of k > 0 cells."""
    return f"{key}_t{int(tolerance)}"


def _check(m: Metric) -> None:
    if m.name in _METRICS:
        raise ValueError(f"metric {m.name!r} is already registered")
    if m.kind not in KINDS:
        raise ValueError(f"metric {m.name!r}: kind must be one of {KINDS}, got {m.kind!r}")
    if (m.compute is None) != (m.kind == "run"):
        raise ValueError(f"metric {m.name!r}: kind 'run' and only it has no compute function")
    if m.keys and not m.columns:
        raise ValueError(f"metric {m.name!r}: reports keys but shows no column")
    taken = {k for other in _METRICS.values() for k in other.keys} - _SHARED_KEYS
    clash = sorted(taken & set(m.keys))
    if clash:
        raise ValueError(f"metric {m.name!r}: keys {clash} are reported by another metric")
    extra = set(m.per_tolerance) - set(m.keys)
    if extra:
        raise ValueError(f"metric {m.name!r}: per_tolerance keys {sorted(extra)} not in keys")
    shown = {c.key for c in _columns()}
    for c in m.columns:
        per_tol = re.fullmatch(r"(.+)_t[1-9][0-9]*", c.key)
        if c.key not in m.keys and not (per_tol and per_tol.group(1) in m.per_tolerance):
            raise ValueError(f"metric {m.name!r}: column {c.key!r} is none of its keys")
        if c.key in shown:
            raise ValueError(f"metric {m.name!r}: column {c.key!r} is already shown")
        shown.add(c.key)
        if c.section and c.section not in _SECTIONS:
            raise ValueError(f"metric {m.name!r}: column {c.key!r}: no section {c.section!r}")
        if c.fallback and c.fallback not in shown:
            raise ValueError(f"metric {m.name!r}: column {c.key!r}: fallback {c.fallback!r} is "
                             "not a column registered before it")
        if c.tolerance is not None and c.higher_is_better is None:
            raise ValueError(f"metric {m.name!r}: column {c.key!r} has a tolerance but no "
                             "better direction")


def register(metric: Metric) -> Metric:
    """Add `metric` after the ones registered so far; ValueError if it is inconsistent."""
    _check(metric)
    _METRICS[metric.name] = metric
    return metric


def unregister(name: str) -> None:
    """Remove the metric `name` (nothing if it is not registered)."""
    _METRICS.pop(name, None)


def register_section(section: Section) -> Section:
    """Add a summary.md table after the ones registered so far."""
    if section.name in _SECTIONS:
        raise ValueError(f"section {section.name!r} is already registered")
    _SECTIONS[section.name] = section
    return section


def load_plugins() -> list[str]:
    """Register every `slam_bench.metrics` entry point (a Metric, or a module whose import
    registers its metrics and sections); their names. A plugin that fails to load or is
    inconsistent with the metrics registered before it raises InputError naming it."""
    global _plugins_loaded
    _plugins_loaded = True   # first: a plugin reading the registry must not load them again
    loaded = []
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            obj = ep.load()
            if isinstance(obj, Metric) and obj.name not in _METRICS:
                register(obj)
        except Exception as err:
            _plugins_loaded = False
            raise InputError(f"metric plugin '{ep.name}' ({ep.value}) failed to load: {err}") from None
        loaded.append(ep.name)
    return loaded


def _ensure_plugins() -> None:
    if not _plugins_loaded:
        load_plugins()


def metrics(kind: str | None = None) -> list[Metric]:
    """The registered metrics (of `kind`), in registration order (the plugins' after the
    built-ins)."""
    _ensure_plugins()
    return [m for m in _METRICS.values() if kind is None or m.kind == kind]


def sections() -> list[Section]:
    """The registered summary.md tables, in registration order."""
    _ensure_plugins()
    return list(_SECTIONS.values())


def _columns() -> list[Column]:
    return [c for m in _METRICS.values() for c in m.columns]


def columns() -> list[Column]:
    """Every shown key, in registration order: the columns of summary.csv."""
    _ensure_plugins()
    return _columns()


def tolerances() -> dict[str, tuple[str, float]]:
    """key -> (direction that is worse, allowed change of the mean) of every checked column."""
    return {c.key: (c.worse, float(c.tolerance)) for c in columns() if c.tolerance is not None}


def _values(m: Metric, ctx) -> dict:
    result = m.compute(ctx)
    if result is None:
        return {}
    values = result.as_dict()
    unknown = sorted(set(values) - set(m.keys))
    if unknown:
        raise ValueError(f"metric {m.name!r} reported undeclared keys {unknown}")
    return values


def compute(kind: str, ctx, extra: bool = True) -> dict:
    """One flat dict of every metric of `kind` on `ctx`, in registration order; extra=False
    skips the metrics registered as extra."""
    out: dict = {}
    for m in metrics(kind):
        if m.compute is not None and (extra or not m.extra):
            out.update(_values(m, ctx))
    return out


def compute_at_tolerance(ctx, tolerance: int) -> dict:
    """The per-tolerance keys of every map metric, computed on `ctx` (a MapContext already
    classified at `tolerance` cells), under their KEY_tk names."""
    out: dict = {}
    for m in metrics("map"):
        if m.per_tolerance:
            values = _values(m, ctx)
            out.update({tolerance_key(k, tolerance): values[k] for k in m.per_tolerance
                        if k in values})
    return out
