"""Speed of score_map on a 7 m x 7 m map at 0.05 m (the swirl_l world), alignment included.

Usage: python tools/metrics_speed.py [--world swirl_l] [--runs 15]
The estimate is the true map seen from a frame moved by (3 cm, -2 cm, 0.5 deg) with 10 % of its
wall cells dropped and 50 noise cells added, i.e. a plausible SLAM result. Prints the median
(and min) wall time of: the first score against a new truth (k-d tree built), later scores
(truth cached, as the benchmark scores many maps against one truth), and global alignment.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from metrics.score import score_map  # noqa: E402
from slam.pose import compose  # noqa: E402
from worlds import load_world, rasterize  # noqa: E402
from worlds.grid import Grid  # noqa: E402


def make_estimate(truth: Grid, rng: np.random.Generator) -> Grid:
    prob = truth.prob.copy()
    occ = np.argwhere(prob >= 0.65)
    drop = occ[rng.choice(len(occ), len(occ) // 10, replace=False)]
    prob[drop[:, 0], drop[:, 1]] = 0.0
    free = np.argwhere(prob <= 0.2)
    add = free[rng.choice(len(free), 50, replace=False)]
    prob[add[:, 0], add[:, 1]] = 1.0
    return Grid(prob, truth.resolution, compose(np.array([0.03, -0.02, np.deg2rad(0.5)]), truth.origin))


def timed(fn, runs: int) -> list[float]:
    out = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--world", default="swirl_l")
    ap.add_argument("--runs", type=int, default=15)
    args = ap.parse_args(argv)
    truth = rasterize(load_world(args.world))
    est = make_estimate(truth, np.random.default_rng(0))
    score_map(est, truth)  # warm-up (imports, caches of this truth)
    print(f"world {args.world}: truth {truth.rows} x {truth.cols} cells at {truth.resolution} m, "
          f"{int(truth.occupied().sum())} occupied; estimate {int(est.occupied().sum())} occupied")

    def fresh():  # a new Grid object each time: nothing cached
        score_map(est, Grid(truth.prob, truth.resolution, truth.origin))

    rows = [("score, new truth (icp)", timed(fresh, args.runs)),
            ("score, cached truth (icp)", timed(lambda: score_map(est, truth), args.runs)),
            ("score, cached truth, no gt-free/ssim", timed(lambda: score_map(est, truth, gtfree=False), args.runs)),
            ("score, cached truth (global)", timed(lambda: score_map(est, truth, initial=None), args.runs))]
    r = score_map(est, truth)
    print(f"result: P {r['precision']:.4f} S {r['sensitivity']:.4f} ADNN {r['adnn_cells']:.3f} cells, "
          f"align {r['align']}")
    for name, ts in rows:
        print(f"{name:40s} median {1000 * statistics.median(ts):7.1f} ms   min {1000 * min(ts):7.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
