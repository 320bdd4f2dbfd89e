"""Run `graph` on recorded logs and print map/trajectory scores and the real-time factor.

    python bench_scripts/graph_speed.py --logs DIR [--worlds a,b] [--config YAML] [--set key=value]

DIR holds WORLD.npz logs from `python -m sim record`; the world name is the file stem.
--no-loop-closure runs the same with pose_graph.enable_loop_closure false.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", required=True)
    ap.add_argument("--worlds", default="")
    ap.add_argument("--config", default=None)
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--no-loop-closure", action="store_true")
    ap.add_argument("--json", default=None, help="write rows here")
    args = ap.parse_args(argv)
    from sim.log import read_log
    from slam.base import run_algorithm
    from worlds import load_world, rasterize
    from metrics import score_map, trajectory_error
    import yaml
    from worlds.yamlio import set_override
    cfg = yaml.safe_load(Path(args.config).read_text()) if args.config else {}
    for s in args.set:
        set_override(cfg, s)
    if args.no_loop_closure:
        set_override(cfg, "pose_graph.enable_loop_closure=false")
    logs = sorted(Path(args.logs).glob("*.npz"))
    if args.worlds:
        want = args.worlds.split(",")
        logs = [p for p in logs if p.stem in want]
    rows = []
    print(f"{'world':12s} {'P':>6s} {'S':>6s} {'ADNN':>6s} {'ATE':>7s} {'end':>7s} {'RTF':>6s} nodes "
          "loops found/tried, see-through")
    for p in logs:
        log = read_log(p)
        r = run_algorithm("graph", log, config=cfg)
        truth = rasterize(load_world(p.stem))
        m = score_map(r.grid, truth, initial=(0.0, 0.0, 0.0), gtfree=False)
        te = trajectory_error(r.times, r.poses, log.gt_t, log.gt_pose)
        from slam.pose import interpolate_poses
        gt_end = interpolate_poses(r.times[-1:], log.gt_t, log.gt_pose)[0]
        end = float(np.hypot(*(r.poses[-1, :2] - gt_end[:2])))
        row = {"world": p.stem, "precision": m["precision"], "sensitivity": m["sensitivity"],
               "adnn_cells": m["adnn_cells"], "ate_m": te["ate_m"], "ate_start_m": te["ate_start_m"],
               "end_error_m": end, **{k: r.stats[k] for k in ("realtime_factor", "wall_time_s", "nodes",
                                                            "loop_closures", "loop_closure_attempts",
                                                            "loop_closures_see_through")}}
        rows.append(row)
        print(f"{p.stem:12s} {row['precision']:6.3f} {row['sensitivity']:6.3f} {row['adnn_cells']:6.3f} "
              f"{row['ate_m']:7.4f} {end:7.4f} {row['realtime_factor']:6.1f} {row['nodes']:5d} "
              f"{row['loop_closures']}/{row['loop_closure_attempts']}, {row['loop_closures_see_through']}",
              flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
