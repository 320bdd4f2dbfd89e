"""Speed (and optionally map quality) of the `pf` SLAM over worlds and seeds.

usage: python bench_scripts/pf_speed.py [--worlds rectangle_m,swirl_s] [--seeds 3]
       [--particles 30] [--config YAML] [--log LOG.npz] [--score] [--jsonl OUT]

For each world the log is recorded once (realistic noise, seed 0; or --log), pf runs once
to compile and warm the numba cache, then once per seed. Printed per run: wall time,
process CPU time and the real-time factors (log duration / time); with --score also
precision, sensitivity, ADNN (metrics.score_map against worlds.rasterize) and ATE
(metrics.trajectory_error). At the end one Markdown table of mean +- std per world.
On a shared machine the CPU-time factor is the one-core speed; stats.json's
realtime_factor is wall time.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np


def run_world(world: str, seeds: int, particles: int, config, log_path, score: bool) -> list[dict]:
    from sim import read_log, record
    from slam.base import load_config, run_algorithm, _ensure_builtin_algorithms
    from worlds import load_world

    _ensure_builtin_algorithms()
    cfg = load_config("pf", config)
    if particles != cfg.particles:
        from dataclasses import replace
        cfg = replace(cfg, particles=particles)
    log = read_log(log_path) if log_path else record(load_world(world), seed=0, noise="realistic")
    run_algorithm("pf", log, config=cfg, seed=0)  # compile / load the numba cache
    truth = None
    if score:
        from worlds import rasterize
        truth = rasterize(load_world(world))
    rows = []
    for seed in range(seeds):
        c0, w0 = time.process_time(), time.perf_counter()
        res = run_algorithm("pf", log, config=cfg, seed=seed)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        row = {"world": world, "seed": seed, "wall_s": wall, "cpu_s": cpu,
               "rtf_wall": res.stats["realtime_factor"], "rtf_cpu": log.duration / cpu,
               "filter_updates": res.stats["filter_updates"], "resamplings": res.stats["resamplings"],
               "map_memory_mb": res.stats["map_memory_mb"]}
        if truth is not None:
            from metrics import score_map, trajectory_error
            sc = score_map(res.grid, truth)
            te = trajectory_error(res.times, res.poses, log.gt_t, log.gt_pose)
            row.update(precision=sc["precision"], sensitivity=sc["sensitivity"],
                       adnn_m=sc["adnn_m"], ate_m=te["ate_m"])
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


def table(rows: list[dict]) -> str:
    """Markdown table of mean +- std per world."""
    keys = [("precision", 3), ("sensitivity", 3), ("adnn_m", 3), ("ate_m", 3),
            ("rtf_wall", 1), ("rtf_cpu", 1)]
    keys = [(k, d) for k, d in keys if k in rows[0]]
    out = ["| world | runs | " + " | ".join(k for k, _ in keys) + " |",
           "|---|---|" + "---|" * len(keys)]
    for world in dict.fromkeys(r["world"] for r in rows):
        sel = [r for r in rows if r["world"] == world]
        cells = []
        for k, d in keys:
            v = np.array([r[k] for r in sel])
            cells.append(f"{v.mean():.{d}f} ± {v.std():.{d}f}")
        out.append(f"| {world} | {len(sel)} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--worlds", default="rectangle_m")
    p.add_argument("--log", default=None, help="use this log (one world) instead of recording")
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--particles", type=int, default=30)
    p.add_argument("--config", default=None, help="pf YAML config")
    p.add_argument("--score", action="store_true", help="also score map and trajectory")
    p.add_argument("--jsonl", default=None, help="append the rows to this file")
    args = p.parse_args(argv)
    rows = []
    for world in args.worlds.split(","):
        rows += run_world(world, args.seeds, args.particles, args.config, args.log, args.score)
    if args.jsonl:
        with open(args.jsonl, "a") as f:
            f.writelines(json.dumps(r) + "\n" for r in rows)
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
