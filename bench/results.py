"""DIR/results.json: one row per world x algorithm x repeat, rewritten atomically as rows finish.

The file is a JSON object {"format": 1, "rows": [...]} with rows sorted by (world, algo, repeat),
so an interrupted-and-resumed run and an uninterrupted run give the same file up to timing
fields (`TIMING_FIELDS`, see `comparable`). Every append rewrites the whole file through a
temporary file and os.replace: a Ctrl-C or a killed process leaves the previous complete file.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Iterable

from worlds.yamlio import InputError, atomic_write_text

__all__ = ["ResultStore", "RESULTS_NAME", "RUN_NAME", "TIMING_FIELDS", "comparable", "read_rows",
           "row_key", "jsonable"]

RESULTS_NAME = "results.json"
RUN_NAME = "run.json"
FORMAT = 1
# fields that differ between two runs of the same rows (machine load, dates, the machine)
TIMING_FIELDS = frozenset({"wall_time_s", "realtime_factor", "update_time_median_s",
                           "update_time_max_s", "finish_time_s", "task_time_s", "score_time_s",
                           "finished_at", "worker", "host", "cpu"})


def row_key(row: dict) -> tuple[str, str, int]:
    return (row["world"], row["algo"], int(row["repeat"]))


def jsonable(value):
    """Plain JSON data: numpy scalars -> Python, NaN/inf -> None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if hasattr(value, "item") and callable(value.item) and getattr(value, "ndim", 0) == 0:
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def comparable(rows: Iterable[dict]) -> list[dict]:
    """Rows without timing fields (also inside `slam_stats`), sorted: for run-vs-resume checks."""
    out = []
    for row in sorted(rows, key=row_key):
        r = {k: v for k, v in row.items() if k not in TIMING_FIELDS}
        if isinstance(r.get("slam_stats"), dict):
            r["slam_stats"] = {k: v for k, v in r["slam_stats"].items()
                               if k not in TIMING_FIELDS and "time" not in k}
        out.append(r)
    return out


def read_rows(path: str | Path) -> list[dict]:
    """Rows of a results.json (a directory or the file); InputError on a missing or bad file."""
    p = Path(path)
    if p.is_dir():
        p = p / RESULTS_NAME
    if not p.is_file():
        raise InputError(f"{p}: file not found")
    try:
        data = json.loads(p.read_text())
    except json.JSONDecodeError as err:
        raise InputError(f"{p}: not valid JSON: {err}") from None
    if not isinstance(data, dict) or not isinstance(data.get("rows"), list):
        raise InputError(f"{p}: not a bench results file (no 'rows' list)")
    return data["rows"]


class ResultStore:
    """The rows of one run directory; `add` stores a row and rewrites results.json atomically."""

    def __init__(self, out_dir: str | Path):
        self.dir = Path(out_dir)
        self.path = self.dir / RESULTS_NAME
        self.rows: dict[tuple, dict] = {}
        if self.path.exists():
            for row in read_rows(self.path):
                self.rows[row_key(row)] = row

    def __contains__(self, key) -> bool:
        return tuple(key) in self.rows

    def __len__(self) -> int:
        return len(self.rows)

    def add(self, row: dict) -> None:
        """Store `row` (replacing one with the same key) and persist the file."""
        row = jsonable(row)
        self.rows[row_key(row)] = row
        self.save()

    def save(self) -> None:
        rows = [self.rows[k] for k in sorted(self.rows)]
        text = json.dumps({"format": FORMAT, "rows": rows}, indent=1, sort_keys=False)
        atomic_write_text(self.path, text + "\n")

    def sorted_rows(self) -> list[dict]:
        return [self.rows[k] for k in sorted(self.rows)]
