"""Speed of the `pf` SLAM: wall and CPU time per log, real-time factors.

usage: python bench_scripts/pf_speed.py [--world rectangle_m] [--seed 0] [--particles 30]
       [--log LOG.npz] [--repeats 3]

Records the world's log (realistic noise, seed 0) unless --log is given, runs pf once to
compile and warm the numba cache, then `repeats` times, and prints for each run the wall
time, the process CPU time and the real-time factors (log duration / time). On a shared
machine the CPU-time figure is the one-core speed; stats.json's realtime_factor is wall time.
"""
from __future__ import annotations

import argparse
import json
import time


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--world", default="rectangle_m")
    p.add_argument("--log", default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--particles", type=int, default=30)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    from sim import read_log, record
    from slam.base import run_algorithm
    from worlds import load_world

    log = read_log(args.log) if args.log else record(load_world(args.world), seed=0, noise="realistic")
    cfg = {"particles": args.particles}
    run_algorithm("pf", log, config=cfg, seed=args.seed)  # compile / load the numba cache
    rows = []
    for k in range(args.repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        res = run_algorithm("pf", log, config=cfg, seed=args.seed + k)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        rows.append({"wall_s": wall, "cpu_s": cpu, "rtf_wall": log.duration / wall,
                     "rtf_cpu": log.duration / cpu, "stats_realtime_factor": res.stats["realtime_factor"],
                     "filter_updates": res.stats["filter_updates"]})
        print(json.dumps(rows[-1]))
    best = max(r["rtf_cpu"] for r in rows)
    print(f"pf, {args.particles} particles, {log.duration:.1f} s log: best {best:.1f}x real time "
          f"(CPU time), {max(r['rtf_wall'] for r in rows):.1f}x (wall)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
