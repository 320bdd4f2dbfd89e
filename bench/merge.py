"""`merge_runs`: join the shards of one run (`bench run --shard K/N`, e.g. the tasks of a SLURM
job array) into one run folder: every row once, the map and true-path files beside them, the
report rebuilt. Shards still missing can be completed afterwards with `bench run --resume`.

Every file is copied from inside its shard folder to inside `out` (worlds.paths.path_inside):
a row's `map_file` of `../X`, or a symlink leading out, is refused before anything is written."""
from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

from worlds.paths import path_inside
from worlds.yamlio import InputError, atomic_write_text, short
from bench.plan import RunSpec
from bench.results import (RESULTS_NAME, RUN_NAME, ResultStore, jsonable, read_rows, read_run,
                           row_key, run_spec)
from bench.rundir import run_lock

__all__ = ["merge_runs"]


def _shards(dirs: list[Path]) -> tuple[RunSpec, list[tuple[Path, dict, RunSpec]]]:
    """(the run's spec without shard, [(dir, run.json, spec)]) after checking the shards
    belong to one run."""
    found = []
    for d in dirs:
        run = read_run(d)
        found.append((d, run, run_spec(run, d / RUN_NAME)))
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


def _copies(found: list[tuple[Path, dict, RunSpec]], rows: dict[tuple, tuple[Path, dict]],
            out: Path) -> list[tuple[Path, Path]]:
    """(source, target) of every file the merge copies: the true maps and true paths of each
    shard (the same in every shard: the first one's is taken), and each row's map. InputError
    when a source resolves outside its shard folder or a target outside `out`."""
    pairs: dict[Path, Path] = {}
    for d, _, _ in found:
        for f in sorted((d / "maps").glob("*/*.npz")):
            rel = f.relative_to(d)
            target = path_inside(out, rel, what=f"{out}: {rel}")
            pairs.setdefault(target, _source(d, rel, f"{d}: {rel}"))
    for d, row in rows.values():
        if row.get("map_file"):
            where = f"{d / RESULTS_NAME}: map_file of {'/'.join(map(str, row_key(row)))}"
            target = path_inside(out, row["map_file"], what=where)
            pairs[target] = _source(d, row["map_file"], where)
    return [(src, target) for target, src in pairs.items()]


def _source(folder: Path, rel: str | Path, where: str) -> Path:
    """folder/rel resolved; InputError naming `where` when it leads outside `folder` (through
    '..' or a symlink): a merge copies nothing from outside the shards."""
    try:
        return path_inside(folder, rel)
    except InputError:
        raise InputError(f"{where}: {short(str(rel))} leads outside the shard folder "
                         f"{short(str(folder))}") from None


def merge_runs(dirs: list[str | Path], out: str | Path) -> tuple[int, list[int]]:
    """Merge shard folders `dirs` into a new run folder `out`; returns (rows, missing shard
    numbers). InputError when the shards are not of one run, a row appears twice, a file
    would be copied from outside a shard or to outside `out`, or `out` already holds a run;
    nothing is written then."""
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
    copies = _copies(found, rows, out)
    with run_lock(out):
        if (out / RUN_NAME).exists():
            raise InputError(f"{out}: already holds a run; merge into a new folder")
        for src, target in copies:
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, target)
        store = ResultStore(out)
        for d, row in rows.values():
            store.rows[row_key(row)] = jsonable(row)
        store.save()
        run = dict(found[0][1])
        run.update(spec=base.to_json(), merged_from=[str(d.resolve()) for d in dirs],
                   missing_shards=[f"{k}/{n}" for k in missing])
        atomic_write_text((out / RUN_NAME).absolute(), json.dumps(jsonable(run), indent=1) + "\n",
                          root=out)
    return len(rows), missing
