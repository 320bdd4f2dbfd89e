"""Quality and speed table of the SLAM core: oracle / gn (or any registered algorithm) on
recorded logs, scored against the worlds' ground truth.

    python -m sim record --world rectangle_s --seed 0 --out LOGS/rectangle_s.npz   # per world
    python bench_scripts/slam_speed.py --logs LOGS --algo oracle,gn [--worlds a,b] [--out DIR]

Prints one Markdown row per world and algorithm: precision, sensitivity (tolerance 0, the
study's rule), ADNN (m), ATE (m, after SE(2) alignment) and the real-time factor from
stats.json (log duration / wall time of the run, numba compilation excluded by a warm-up
run on the first log). With --out, every run's result files are written to DIR/ALGO/WORLD.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

WORLDS = ["rectangle_s", "rectangle_m", "rectangle_l", "swirl_s", "swirl_m", "swirl_l", "corridor"]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--logs", required=True, help="directory with WORLD.npz logs")
    p.add_argument("--algo", default="oracle,gn")
    p.add_argument("--worlds", default=",".join(WORLDS))
    p.add_argument("--config", default=None, help="config YAML passed to every algorithm")
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)

    from metrics import score_map, trajectory_error
    from sim.log import read_log
    from slam.base import run_algorithm
    from slam.io import write_result
    from worlds.load import load_world
    from worlds.raster import rasterize

    print("| algo | world | P | S | ADNN m | ATE m | RTF | wall s |")
    print("|---|---|---|---|---|---|---|---|")
    for algo in args.algo.split(","):
        warm = False
        for world in args.worlds.split(","):
            log = read_log(Path(args.logs) / f"{world}.npz")
            if not warm:  # compile (or load the numba cache) outside the timed run
                t0 = time.perf_counter()
                short = type(log)(**{**log.__dict__, "scan_t": log.scan_t[:5], "scan_ranges": log.scan_ranges[:5]})
                run_algorithm(algo, short, config=args.config)
                print(f"<!-- {algo}: warm-up {time.perf_counter() - t0:.2f} s -->", file=sys.stderr)
                warm = True
            res = run_algorithm(algo, log, config=args.config)
            if args.out:
                write_result(res, Path(args.out) / algo / world)
            truth = rasterize(load_world(world))
            s = score_map(res.grid, truth, gtfree=False)
            tr = trajectory_error(res.times, res.poses, log.gt_t, log.gt_pose)
            st = res.stats
            print(f"| {algo} | {world} | {s['precision']:.3f} | {s['sensitivity']:.3f} | {s['adnn_m']:.4f} "
                  f"| {tr['ate_m']:.4f} | {st['realtime_factor']:.1f} | {st['wall_time_s']:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
