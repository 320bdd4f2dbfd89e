"""`merge_runs`: join the shards of one run (`bench run --shard K/N`, e.g. the tasks of a SLURM
job array) into one run folder: every row once, the map and true-path files beside them, the
report rebuilt. Shards still missing can be completed afterwards with `bench run --resume`."""
from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

from worlds.yamlio import InputError, atomic_write_text
from bench.plan import RunSpec
from bench.results import RUN_NAME, ResultStore, jsonable, read_rows, row_key
from bench.runner import read_run, run_lock

__all__ = ["merge_runs"]


def _shards(dirs: list[Path]) -> tuple[RunSpec, list[tuple[Path, dict, RunSpec]]]:
    """(the run's spec without shard, [(dir, run.json, spec)]) after checking the shards
    belong to one run."""
    found = []
    for d in dirs:
        run = read_run(d)
        found.append((d, run, RunSpec.from_json(run["spec"])))
    base = dataclasses.replace(found[0][2], shard=(1, 1))
    seen: dict[int, Path] = {}
    for d, _, spec in found:
        if dataclasses.replace(spec, shard=(1, 1)) != base:
            raise InputError(f"{d}: a shard of another run than {found[0][0]} (its arguments differ)")
        if spec.shard[1] != found[0][2].shard[1]:
            raise InputError(f"{d}: shard {spec.shard[0]}/{spec.shard[1]} of a run cut into "
                             f"{found[0][2].shard[1]}, not {found[0][2].shard[1]}")
        if spec.shard[0] in seen:
            raise InputError(f"{d}: shard {spec.shard[0]}/{spec.shard[1]} again (also {seen[spec.shard[0]]})")
        seen[spec.shard[0]] = d
    return base, found


def merge_runs(dirs: list[str | Path], out: str | Path) -> tuple[int, list[int]]:
    """Merge shard folders `dirs` into a new run folder `out`; returns (rows, missing shard
    numbers). InputError when the shards are not of one run, a row appears twice, or `out`
    already holds a run."""
    dirs = [Path(d) for d in dirs]
    out = Path(out)
    if not dirs:
        raise InputError("merge: no shard folder given")
    base, found = _shards(dirs)
    rows: dict[tuple, tuple[Path, dict]] = {}
    for d, _, _ in found:
        for row in read_rows(d):
            key = row_key(row)
            if key in rows:
                raise InputError(f"{d}: row {'/'.join(map(str, key))} is also in {rows[key][0]}")
            rows[key] = (d, row)
    n = found[0][2].shard[1]
    missing = sorted(set(range(1, n + 1)) - {spec.shard[0] for _, _, spec in found})
    with run_lock(out):
        if (out / RUN_NAME).exists():
            raise InputError(f"{out}: already holds a run; merge into a new folder")
        for d, _, _ in found:   # true maps and true paths: the same in every shard
            for f in (d / "maps").glob("*/*.npz"):
                target = out / f.relative_to(d)
                if not target.exists():
                    target.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copyfile(f, target)
        store = ResultStore(out)
        for d, row in rows.values():
            if row.get("map_file"):
                target = out / row["map_file"]
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(d / row["map_file"], target)
            store.rows[row_key(row)] = jsonable(row)
        store.save()
        run = dict(found[0][1])
        run.update(spec=base.to_json(), merged_from=[str(d.resolve()) for d in dirs],
                   missing_shards=[f"{k}/{n}" for k in missing])
        atomic_write_text(out / RUN_NAME, json.dumps(jsonable(run), indent=1) + "\n")
    return len(rows), missing
