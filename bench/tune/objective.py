"""What a tune optimises, read from a bench run's rows: the mean of one row field, its direction,
its value over the first worlds of a run (for pruning) and its spread over noise draws."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Objective", "OBJECTIVES", "get_objective", "world_prefix_values", "per_draw",
           "excluded_rows", "per_world"]


@dataclass(frozen=True)
class Objective:
    """name; the row field averaged (the first a run's rows hold); maximize or minimize; unit."""

    name: str
    fields: tuple[str, ...]
    direction: str
    unit: str
    label: str

    def value(self, row: dict) -> float | None:
        """This objective's value of one ok row (None when the row lacks it)."""
        for f in self.fields:
            v = row.get(f)
            if v is not None:
                return float(v)
        return None

    def better(self, a: float, b: float) -> bool:
        """True when value `a` is better than `b`."""
        return a > b if self.direction == "maximize" else a < b


OBJECTIVES = {
    # surface F1 is bench's main map score; the study's cell F1 where a truth is only a raster
    "f1": Objective("f1", ("surface_f1", "f1"), "maximize", "", "mean map F1"),
    "ate": Objective("ate", ("ate_m",), "minimize", "m", "mean ATE (m)"),
    # logs with relation files (bench.tune.logset): the mean absolute translational error
    "relations": Objective("relations", ("relations_abs_trans_m",), "minimize", "m",
                           "mean relation error (m)"),
}


def get_objective(name: str) -> Objective:
    """The objective called `name` (KeyError is the CLI's choices' job)."""
    return OBJECTIVES[name]


def _key(row: dict) -> tuple[str, int]:
    return row["world"], int(row.get("draw") or 0)


def excluded_rows(default_rows: list[dict]) -> dict[tuple[str, int], str]:
    """(world, draw) -> reason, of the rows that failed under the default config: a log that
    cannot be trusted, or a world where the defaults fail. Every trial leaves them out alike,
    and the report lists them."""
    return {_key(r): str(r.get("error") or "failed") for r in default_rows
            if r.get("status") != "ok"}


def world_prefix_values(objective: Objective, rows: list[dict], world_order: list[str],
                        n_rows_of: dict[str, int], excluded: dict) -> list[float]:
    """The objective's mean over the rows of the first k worlds, for every k whose worlds are
    all done (a prefix of `world_order`), in order: the steps a pruner is shown. n_rows_of:
    how many rows each world has in a complete run."""
    by_world: dict[str, list[float]] = {}
    done: dict[str, int] = {}
    for r in rows:
        done[r["world"]] = done.get(r["world"], 0) + 1
        if _key(r) in excluded or r.get("status") != "ok":
            continue
        v = objective.value(r)
        if v is not None:
            by_world.setdefault(r["world"], []).append(v)
    out, pooled = [], []
    for w in world_order:
        if done.get(w, 0) < n_rows_of[w]:
            break
        pooled += by_world.get(w, [])
        if pooled:
            out.append(float(np.mean(pooled)))
    return out


def _means_by(objective: Objective, rows: list[dict], excluded: dict, group) -> dict:
    by: dict = {}
    for r in rows:
        if r.get("status") != "ok" or _key(r) in excluded:
            continue
        v = objective.value(r)
        if v is not None:
            by.setdefault(group(r), []).append(v)
    return {k: float(np.mean(v)) for k, v in by.items()}


def per_draw(objective: Objective, rows: list[dict], excluded: dict) -> dict[int, float]:
    """draw -> the objective's mean over that draw's ok rows (not excluded)."""
    return dict(sorted(_means_by(objective, rows, excluded, lambda r: int(r.get("draw") or 0)).items()))


def per_world(objective: Objective, rows: list[dict], excluded: dict) -> dict[str, float]:
    """world -> the objective's mean over its ok rows (not excluded)."""
    return _means_by(objective, rows, excluded, lambda r: r["world"])
