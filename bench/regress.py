"""Regression check: rerun a small fixed matrix and compare its means with a committed baseline.

The baseline (bench/baseline.json) stores the matrix it was made with (worlds, algorithms,
repeats, seed, noise) and, per world/algorithm, the mean of each checked metric and the
number of failed repeats. `regress()` reruns that matrix and reports every mean that got
worse by more than its tolerance (`default_tolerances()`: the tolerances of the columns of
metrics.registry, e.g. precision/sensitivity of both the surface form and the study's cell
rule may drop by 0.03, ADNN rise by 0.3 cells, ATE by 0.02 m; and no new failures). A
baseline keeps the tolerances it was written with; a metric checked now that the baseline
does not hold (written before the metric existed) is skipped with a note (`unchecked`).
Getting better never fails; refresh the baseline with update=True (`--update`) when a
change is meant.
"""
from __future__ import annotations

import json
import math
import sys
import tempfile
from pathlib import Path

from metrics import registry
from worlds.yamlio import InputError, atomic_write_text, short
from bench.plan import RunSpec, resolve_algos
from bench.results import jsonable, read_json, read_rows
from bench.tables import mean_std

__all__ = ["BASELINE_PATH", "DEFAULT_WORLDS", "DEFAULT_REPEATS", "default_tolerances",
           "summarize", "compare", "unchecked", "regress"]

BASELINE_PATH = Path(__file__).with_name("baseline.json")
DEFAULT_WORLDS = ("rectangle_s", "swirl_s")
DEFAULT_REPEATS = 2


def default_tolerances() -> dict[str, tuple[str, float]]:
    """metric -> (direction that is worse, allowed change of the mean): every checked column
    of metrics.registry, and `failed` (no new failures)."""
    return {**registry.tolerances(), "failed": ("rise", 0.0)}


def summarize(rows: list[dict], metrics=None) -> dict[str, dict]:
    """'world/algo' -> {metric: mean over ok rows (None if none), 'failed': count, 'n': count};
    metrics: the keys to average (default: those of default_tolerances())."""
    metrics = default_tolerances() if metrics is None else metrics
    groups: dict[str, list[dict]] = {}
    for r in rows:
        groups.setdefault(f"{r['world']}/{r['algo']}", []).append(r)
    out = {}
    for key, rs in sorted(groups.items()):
        ok = [r for r in rs if r.get("status") == "ok"]
        entry = {"n": len(rs), "failed": len(rs) - len(ok)}
        for m in metrics:
            if m == "failed":
                continue
            mean, _, n = mean_std(r.get(m) for r in ok)
            entry[m] = mean if n else None
        out[key] = entry
    return out


def compare(baseline: dict[str, dict], current: dict[str, dict],
            tolerances=None) -> list[str]:
    """Lines describing every metric of `current` worse than `baseline` beyond its tolerance
    (default: default_tolerances())."""
    tolerances = default_tolerances() if tolerances is None else tolerances
    worse = []
    for key, base in sorted(baseline.items()):
        cur = current.get(key)
        if cur is None:
            worse.append(f"{key}: missing from this run")
            continue
        for m, (direction, tol) in tolerances.items():
            b, c = base.get(m), cur.get(m)
            if b is None:
                continue
            if c is None or (isinstance(c, float) and math.isnan(c)):
                worse.append(f"{key}: {m} has no value now (baseline {b:.4g})")
                continue
            change = (b - c) if direction == "drop" else (c - b)
            if change > tol + 1e-12:
                verb = "dropped" if direction == "drop" else "rose"
                worse.append(f"{key}: {m} {verb} from {b:.4g} to {c:.4g} "
                             f"(by {change:.4g}, tolerance {tol:g})")
    return worse


def unchecked(baseline: dict[str, dict], tolerances=None) -> list[str]:
    """The metrics of `tolerances` (default: default_tolerances()) that no entry of
    `baseline` holds a value of: not checked (a baseline older than the metric)."""
    tolerances = default_tolerances() if tolerances is None else tolerances
    return [m for m in tolerances
            if not any(base.get(m) is not None for base in baseline.values())]


def _load_baseline(path: Path) -> dict:
    """The baseline file, checked (_check_baseline); InputError naming the file and field."""
    if not path.is_file():
        raise InputError(f"{path}: no baseline file (create one with --update)")
    data = read_json(path, "bench baseline")
    if "matrix" not in data or "means" not in data:
        raise InputError(f"{path}: not a bench baseline (needs 'matrix' and 'means')")
    _check_baseline(data, str(path))
    return data


def _check_baseline(data: dict, where: str) -> None:
    """InputError '<where>: FIELD: problem' unless the matrix, means and tolerances have the
    types regress() reads (a hand-edited baseline must fail in one line, not in a format)."""
    matrix, means = data["matrix"], data["means"]
    if not isinstance(matrix, dict):
        raise InputError(f"{where}: matrix: expected a mapping, got {short(matrix)}")
    for key in ("worlds", "algos"):   # each key may be absent: regress() has defaults
        v = matrix.get(key, ["default"])
        if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
            raise InputError(f"{where}: matrix.{key}: expected a list of names, got {short(v)}")
    for key, low in (("repeats", 1), ("seed", 0)):
        v = matrix.get(key, low)
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise InputError(f"{where}: matrix.{key}: expected an integer >= {low}, got {short(v)}")
    if not isinstance(matrix.get("noise", ""), str):
        raise InputError(f"{where}: matrix.noise: expected a name, got {short(matrix['noise'])}")
    if not isinstance(means, dict):
        raise InputError(f"{where}: means: expected a mapping, got {short(means)}")
    for pair, entry in means.items():
        if not isinstance(entry, dict):
            raise InputError(f"{where}: means.{pair}: expected a mapping, got {short(entry)}")
        for m, v in entry.items():
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
                raise InputError(f"{where}: means.{pair}.{m}: expected a number or null, got "
                                 f"{short(v)}")
    tolerances = data.get("tolerances", {})
    if not isinstance(tolerances, dict):
        raise InputError(f"{where}: tolerances: expected a mapping, got {short(tolerances)}")
    for m, v in tolerances.items():
        if not (isinstance(v, list) and len(v) == 2 and v[0] in ("drop", "rise")
                and isinstance(v[1], (int, float)) and not isinstance(v[1], bool)
                and math.isfinite(v[1])):
            raise InputError(f"{where}: tolerances.{m}: expected [\"drop\" or \"rise\", a number], "
                             f"got {short(v)}")


def _matrix(base: dict | None, worlds, algos, repeats, seed: int, noise: str) -> dict:
    """The matrix to run: the baseline's (none when writing one), with what is given on top
    and the defaults for the rest; its algorithms checked."""
    matrix = dict(base["matrix"]) if base else {}
    if worlds is not None:
        matrix["worlds"] = list(worlds)
    if algos is not None:
        matrix["algos"] = list(algos)
    if repeats is not None:
        matrix["repeats"] = repeats
    matrix.setdefault("worlds", list(DEFAULT_WORLDS))
    matrix.setdefault("algos", resolve_algos(None))
    matrix.setdefault("repeats", DEFAULT_REPEATS)
    matrix.setdefault("seed", seed)
    matrix.setdefault("noise", noise)
    resolve_algos(",".join(matrix["algos"]))
    return matrix


def regress(baseline: str | Path | None = None, update: bool = False, worlds=None, algos=None,
            repeats: int | None = None, seed: int = 0, noise: str = "realistic",
            jobs: int | None = None, out: str | Path | None = None, stream=None,
            progress: bool = True) -> int:
    """Rerun the baseline's matrix (or the one given) and compare; returns the exit code.

    0: nothing got worse (or update=True wrote the baseline); 1: something got worse (listed
    on `stream`). Without update the matrix comes from the baseline file unless given.
    """
    from bench.runner import print_outcome, run_benchmark
    stream = stream or sys.stdout
    path = Path(baseline) if baseline else BASELINE_PATH
    base = None if update else _load_baseline(path)
    matrix = _matrix(base, worlds, algos, repeats, seed, noise)
    spec = RunSpec(worlds=tuple(matrix["worlds"]), algos=tuple(matrix["algos"]),
                   repeats=int(matrix["repeats"]), noise=matrix["noise"], seed=int(matrix["seed"]),
                   vary="slam")
    with tempfile.TemporaryDirectory(prefix="bench-regress-") as tmp:
        out_dir = Path(out) if out else Path(tmp) / "run"
        outcome = run_benchmark(spec, out_dir, jobs=jobs, progress=progress,
                                argv=["regress"])
        if not outcome.complete:
            print_outcome(outcome)
            return 130 if outcome.interrupted else 1
        current = summarize(read_rows(out_dir))
    if update:
        data = {"matrix": matrix,
                "tolerances": {k: list(v) for k, v in default_tolerances().items()},
                "means": current}
        atomic_write_text(path, json.dumps(jsonable(data), indent=1, sort_keys=True) + "\n")
        print(f"baseline written: {path} ({len(current)} world/algorithm pairs)", file=stream)
        return 0
    # the baseline's own tolerances, and today's for the metrics it predates
    tolerances = {**default_tolerances(),
                  **{k: (v[0], float(v[1])) for k, v in base.get("tolerances", {}).items()}}
    worse = compare(base["means"], current, tolerances)
    new = sorted(set(current) - set(base["means"]))
    if new:
        print(f"not in the baseline (not checked): {', '.join(new)}", file=stream)
    missing = unchecked(base["means"], tolerances)
    if missing:
        print(f"metrics the baseline has no value of (not checked; refresh it with --update): "
              f"{', '.join(missing)}", file=stream)
    if worse:
        print(f"regression: {len(worse)} metric(s) got worse than {path}:", file=stream)
        for line in worse:
            print(f"  {line}", file=stream)
        return 1
    print(f"no regression against {path} ({len(base['means'])} world/algorithm pairs)", file=stream)
    return 0
