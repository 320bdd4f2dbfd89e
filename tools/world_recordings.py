"""Do worlds record completely? Every shipped world and generated worlds of each kind.

    python tools/world_recordings.py [--seeds 0-9] [--noise realistic] [--log-seed 0]

For each shipped world and each generated world (every kind of worlds.generate, the given
generator seeds, default size) records one log and prints a markdown table: how the log
ended, the share of the route driven, the lidar's wall coverage, the log's duration, the
distance from the true path's end to its start (a closed route comes back), and the
generation and recording times. Exits 1 if any log cannot be trusted
(sim.recording_problem).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _seeds(text: str) -> list[int]:
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(t) for t in text.split(",")]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-9", help="generator seeds, e.g. 0-9 or 0,3")
    ap.add_argument("--noise", default="realistic")
    ap.add_argument("--log-seed", type=int, default=0)
    ap.add_argument("--kinds", default=None, help="comma-separated kinds (default: all)")
    ap.add_argument("--no-shipped", action="store_true")
    args = ap.parse_args(argv)

    import sim
    import worlds
    from worlds.generate import KINDS, generate_yaml

    jobs = [] if args.no_shipped else [(name, None, None) for name in worlds.list_worlds()]
    kinds = args.kinds.split(",") if args.kinds else KINDS
    jobs += [(kind, kind, seed) for kind in kinds for seed in _seeds(args.seeds)]
    print("| world | ending | route driven | wall coverage | log (s) | end to start (m) | "
          "generate (s) | record (s) |")
    print("|---|---|---|---|---|---|---|---|")
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name, kind, seed in jobs:
            t0 = time.perf_counter()
            if kind is not None:
                path = Path(tmp) / f"{kind}_s{seed}.yaml"
                path.write_text(generate_yaml(kind, seed))
                world = worlds.load_world(str(path))
            else:
                world = worlds.load_world(name)
            t1 = time.perf_counter()
            log = sim.record(world, seed=args.log_seed, noise=args.noise)
            t2 = time.perf_counter()
            m = log.meta
            back = float(np.hypot(*(log.gt_pose[-1, :2] - log.gt_pose[0, :2])))
            problem = sim.recording_problem(m)
            bad += problem is not None
            print(f"| {world.name} | {m['ending']} | {m['route_driven']:.3f} | "
                  f"{m['wall_coverage']:.4f} | {log.gt_t[-1]:.0f} | {back:.3f} | "
                  f"{t1 - t0 if kind else 0:.1f} | {t2 - t1:.1f} |"
                  + (f" {problem}" if problem else ""), flush=True)
    print(f"\n{len(jobs) - bad} of {len(jobs)} logs can be trusted")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
