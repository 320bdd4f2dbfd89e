"""Every SLAM on the MIT CSAIL raw log, scored with the Kuemmerle relations metric.

    python tools/csail.py [--data DIR] [--algo graph,pf,gn] [--config ALGO=FILE ...] [--out DIR]
                          [--seed S]
    python tools/csail.py --logset FILE [--data DIR]   # a log set naming the log and its
                                                       # relations (bench tune --objective relations)

Reads DIR/csail.corrected.gfs (406 raw scans, raw odometry at all 1988 scan times) and
DIR/mit-csail.relations, runs each algorithm with its defaults (what it derives from the log;
--config gives one a YAML file), looks its
trajectory up at the relation times (poses between its scans carried by the odometry from the
nearest scan, see metrics/relations.py) and prints, beside the published rows, the four error
statistics over all 1172 relations and the absolute translational error over the relations
shorter than and at least 5 s long, with the wall time against the data duration (424 s of
odometry, Hess et al. 2016 Table V). Raw odometry is the baseline row. `oracle` cannot run:
the log has no ground truth. Writes OUT/results.json, OUT/table.md and OUT/<algo>/ (map,
trajectory, stats).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from metrics.relations import read_relations, relations_error  # noqa: E402
from sim.logs import import_log  # noqa: E402
from worlds.jsonio import dumps  # noqa: E402
from worlds.yamlio import InputError  # noqa: E402

DEFAULT_DATA = ROOT.parent / "shared" / "data" / "radish"

# mean +- std over all relations: abs trans (m), sq trans (m^2), abs rot (deg), sq rot (deg^2);
# wall time (s) for the 424 s of data. Sources: ../shared/data/radish/PUBLISHED.md and README.md.
PUBLISHED = [
    ("Cartographer (Hess et al. 2016, Table II/V)", (0.0319, 0.0363), (0.0023, 0.0099),
     (0.369, 0.365), (0.270, 0.637), 35.0),
    ("Graph Mapping (Kuemmerle et al. 2009, via Hess)", (0.004, 0.009), (0.0001, 0.0005),
     (0.05, 0.08), (0.01, 0.04), None),
    ("RBPF / GMapping (Kuemmerle 2009, secondary)", (0.049, 0.049), None, None, None, None),
    ("scan matching (Kuemmerle 2009, secondary)", (0.106, 0.325), None, None, None, None),
    ("MRPT 2.5.8 rbpf-slam, measured here", (0.259, 0.659), None, None, None, 72.0),
    ("MRPT 2.5.8 icp-slam, measured here", (0.295, 0.829), None, None, None, 2.9),
]


def _pm(pair, digits=4) -> str:
    if pair is None:
        return "-"
    return f"{pair[0]:.{digits}f} ± {pair[1]:.{digits}f}"


def score_row(name: str, res: dict, wall: float | None, duration: float) -> dict:
    row = {"name": name, "wall_time_s": wall,
           "realtime_factor": (duration / wall) if wall else None, "relations": res}
    return row


def format_table(rows: list[dict], duration: float) -> str:
    head = ("| method | abs trans (m) | sq trans (m²) | abs rot (deg) | sq rot (deg²) | "
            "abs trans < 5 s (m) | abs trans ≥ 5 s (m) | wall (s) | × real time |")
    lines = [head, "|" + "---|" * 9]
    for r in rows:
        s = r["relations"]
        wall = r["wall_time_s"]
        lines.append(
            f"| {r['name']} | {_pm((s['abs_trans_mean'], s['abs_trans_std']))} | "
            f"{_pm((s['sq_trans_mean'], s['sq_trans_std']), 5)} | "
            f"{_pm((s['abs_rot_deg_mean'], s['abs_rot_deg_std']), 3)} | "
            f"{_pm((s['sq_rot_deg2_mean'], s['sq_rot_deg2_std']), 2)} | "
            f"{_pm((s['short']['abs_trans_mean'], s['short']['abs_trans_std']))} | "
            f"{_pm((s['long']['abs_trans_mean'], s['long']['abs_trans_std']))} | "
            f"{'-' if wall is None else f'{wall:.1f}'} | "
            f"{'-' if wall is None else f'{duration / wall:.1f}'} |")
    for name, at, st, ar, sr, wall in PUBLISHED:
        lines.append(f"| {name} | {_pm(at)} | {_pm(st, 5)} | {_pm(ar, 3)} | {_pm(sr, 2)} | - | - | "
                     f"{'-' if wall is None else f'{wall:.1f}'} | "
                     f"{'-' if wall is None else f'{424.0 / wall:.1f}'} |")
    return "\n".join(lines)


def write_logset(path: Path, data: Path) -> int:
    """A log set (bench.tune.logset) of the CSAIL log and its relations, by absolute path."""
    from worlds.yamlio import atomic_write_text, dump_yaml
    log, rel = (data / "csail.corrected.gfs").resolve(), (data / "mit-csail.relations").resolve()
    for f in (log, rel):
        if not f.is_file():
            raise InputError(f"--data {data}: {f.name}: file not found")
    atomic_write_text(path, dump_yaml({"name": "csail", "description": "MIT CSAIL, raw odometry",
                                       "logs": [{"log": str(log), "relations": str(rel),
                                                 "name": "csail"}]}))
    print(f"log set: {path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=str(DEFAULT_DATA), help="folder with the Radish files")
    ap.add_argument("--algo", default="graph,pf,gn", help="comma-separated algorithms "
                                                          "(default graph,pf,gn)")
    ap.add_argument("--config", action="append", default=[], metavar="ALGO=FILE",
                    help="run ALGO with the config FILE instead of its defaults (repeatable)")
    ap.add_argument("--out", default="csail_bench", help="output folder")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--logset", type=Path, metavar="FILE",
                    help="write a log set YAML naming the CSAIL log and its relations; run nothing")
    args = ap.parse_args(argv)
    try:
        if args.logset:
            return write_logset(args.logset, Path(args.data))
        configs = dict(c.split("=", 1) for c in args.config if "=" in c)
        if len(configs) != len(args.config):
            raise InputError(f"--config: expected ALGO=FILE, got {args.config}")
        return run(Path(args.data), args.algo, Path(args.out), args.seed, configs)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


def run(data: Path, algos: str, out: Path, seed: int, configs: dict | None = None) -> int:
    from slam.registry import names as algorithm_names
    from slam.replay import run_algorithm
    from slam.io import write_result

    known = algorithm_names()
    log = import_log(data / "csail.corrected.gfs")
    rel = read_relations(data / "mit-csail.relations")
    odom = (log.odom_t, log.odom_pose)
    duration = float(log.odom_t[-1] - log.odom_t[0])   # 424.0 s, the paper's data duration
    names = [a.strip() for a in algos.split(",") if a.strip()]
    configs = configs or {}
    print(f"CSAIL: {log.n_scans} scans, {len(log.odom_t)} odometry poses, {duration:.1f} s of data; "
          f"{len(rel)} relations; algorithms: {', '.join(names) or 'none registered'}", flush=True)
    out.mkdir(parents=True, exist_ok=True)
    rows = [score_row("raw odometry", relations_error(log.odom_t, log.odom_pose, rel), None, duration)]
    for name in names:
        if name not in known:
            print(f"  {name}: not registered in this checkout, skipped", flush=True)
            continue
        t0 = time.perf_counter()
        result = run_algorithm(name, log, config=configs.get(name), seed=seed)
        wall = time.perf_counter() - t0
        write_result(result, out / name)
        res = relations_error(result.times, result.poses, rel, odom)
        rows.append(score_row(name, res, wall, duration))
        rows[-1]["stats"] = result.stats
        print(f"  {name}: {res['abs_trans_mean']:.4f} ± {res['abs_trans_std']:.4f} m over "
              f"{res['n_used']} relations (≥ 5 s: {res['long']['abs_trans_mean']:.4f} m), "
              f"{wall:.1f} s wall, {duration / wall:.1f}x real time", flush=True)
    table = format_table(rows, duration)
    (out / "table.md").write_text(table + "\n")
    (out / "results.json").write_text(dumps({"duration_s": duration, "rows": rows}, indent=1))
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
