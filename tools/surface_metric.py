"""The surface form of the grid portion on the oracle's maps: tau, grid offsets, wrong maps.

    python tools/surface_metric.py [--seeds 0-9] [--draws 3] [--taus 0,0.005,0.01,0.015,0.02]
                                           [--shifts 0,0.01,0.025,0.04] [--jobs 2] [--out FILE.json]

For every shipped world and the generated worlds of each kind (generator seeds --seeds,
default size) and each noise draw (log seeds 0 .. draws-1, realistic profile): records the
log, maps it with the oracle (true poses), aligns as `bench` does and scores
 - the study's exact cell rule (precision, sensitivity at tolerance 0),
 - the surface form at each tau,
 - the surface form of the oracle's map moved by one cell in each of the four directions,
 - with --shifts, the surface form of the oracle on the whole world shifted by a fraction of
   a cell (draw 0; the log re-recorded in the shifted world).
Prints markdown tables (per world: mean over draws; min over everything) and writes every
number to --out.
"""
from __future__ import annotations

import argparse
import functools
import json
import time
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _seeds(text: str) -> list[int]:
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(t) for t in text.split(",") if t]


@functools.lru_cache(maxsize=4)
def _world_data_cached(ref: str) -> str:
    return json.dumps(_world_data(ref))


def _world_data(ref: str) -> dict:
    """World YAML data of a shipped world name or 'kind:seed'."""
    from worlds.generate import generate_world
    from worlds.load import world_dir
    from worlds.yamlio import load_yaml
    if ":" in ref:
        kind, seed = ref.split(":")
        return generate_world(kind, int(seed))
    return load_yaml(world_dir() / f"{ref}.yaml")


def _shifted(data, dx: float, dy: float):
    """The same world data with every coordinate moved by (dx, dy)."""
    def move(v):
        if isinstance(v, list) and len(v) == 2 and all(isinstance(c, (int, float)) for c in v):
            return [v[0] + dx, v[1] + dy]
        if isinstance(v, list):
            return [move(x) for x in v]
        if isinstance(v, dict):
            return {k: (move(x) if k not in ("size", "radius", "yaw", "sides", "thickness") else x)
                    for k, x in v.items()}
        return v
    out = dict(data)
    out["walls"] = move(data["walls"])
    if data.get("obstacles"):
        out["obstacles"] = move(data["obstacles"])
    s = data["robot"]["start"]
    out["robot"] = {"start": [s[0] + dx, s[1] + dy, s[2]]}
    if data.get("route") is not None:
        out["route"] = move(data["route"])
    return out


def _oracle_scores(data: dict, log_seed: int, taus: list[float], moves: bool) -> dict:
    import metrics
    import sim
    from metrics.surface import classify_surface, visible_surfaces
    from slam.replay import run_algorithm
    from worlds import rasterize
    from worlds.grid import Grid
    from worlds.load import world_from_dict
    world = world_from_dict(data, where=data.get("name", "world"))
    log = sim.record(world, seed=log_seed, noise="realistic")
    result = run_algorithm("oracle", log, seed=0)
    truth = rasterize(world)
    s = metrics.score_map(result.grid, truth, align="auto", initial=(0.0, 0.0, 0.0), gtfree=False)
    pose = np.array([s["align"]["x"], s["align"]["y"], s["align"]["yaw"]])
    segs = visible_surfaces(world)
    out = {"cell_p": s["precision"], "cell_s": s["sensitivity"],
           "coverage": log.meta["wall_coverage"], "ending": log.meta["ending"]}
    for tau in taus:
        c = classify_surface(result.grid, segs, pose, tau).counts
        out[f"p_{tau:g}"] = c["surface_precision"]
        out[f"s_{tau:g}"] = c["surface_sensitivity"]
    perfect = classify_surface(truth, segs, (0.0, 0.0, 0.0), taus[len(taus) // 2]).counts
    out["truth_p"], out["truth_s"] = perfect["surface_precision"], perfect["surface_sensitivity"]
    if moves:
        g = result.grid
        for name, (dc, dr) in {"+x": (1, 0), "-x": (-1, 0), "+y": (0, 1), "-y": (0, -1)}.items():
            moved = Grid(g.prob, g.resolution, g.origin + [dc * g.resolution, dr * g.resolution, 0.0])
            for tau in taus:
                c = classify_surface(moved, segs, pose, tau).counts
                out[f"moved{name}_p_{tau:g}"] = c["surface_precision"]
                out[f"moved{name}_s_{tau:g}"] = c["surface_sensitivity"]
    return out


def _job(args):
    ref, log_seed, shift, taus = args
    data = json.loads(_world_data_cached(ref))   # a fresh copy: generating an office takes 10 s
    if shift:
        data = _shifted(data, shift, shift)
    name = data.get("name", ref)
    return {"world": name, "ref": ref, "draw": log_seed, "shift": shift,
            **_oracle_scores(data, log_seed, taus, moves=shift == 0.0)}


def _time_surface_form() -> int:
    """Median wall time of classify_surface on the true map of a 10 m x 10 m office."""
    from metrics.surface import classify_surface, visible_surfaces
    from worlds import rasterize
    from worlds.generate import generate_world
    from worlds.load import world_from_dict
    world = world_from_dict(generate_world("office", 0, (10.0, 10.0)), where="office 10x10")
    truth = rasterize(world)
    segs = visible_surfaces(world)
    classify_surface(truth, segs, (0.0, 0.0, 0.0))           # compile or load the kernel
    times = []
    for _ in range(7):
        t0 = time.perf_counter()
        c = classify_surface(truth, segs, (0.01, -0.02, 0.003))
        times.append(time.perf_counter() - t0)
    print(f"{world.name}: {truth.rows} x {truth.cols} cells, {len(segs)} surface segments, "
          f"{c.counts['surface_tp'] + c.counts['surface_fp']} occupied cells: surface form "
          f"median {1000 * np.median(times):.1f} ms (min {1000 * min(times):.1f}, "
          f"max {1000 * max(times):.1f}) over {len(times)} runs")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-9")
    ap.add_argument("--kinds", default="office,warehouse,hall,loop")
    ap.add_argument("--draws", type=int, default=3)
    ap.add_argument("--taus", default="0,0.005,0.01,0.015,0.02")
    ap.add_argument("--shifts", default="")
    ap.add_argument("--no-shipped", action="store_true")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=None)
    ap.add_argument("--time", action="store_true",
                    help="only time the surface form on a 10 m x 10 m office's true map")
    args = ap.parse_args(argv)
    if args.time:
        return _time_surface_form()
    import worlds
    taus = [float(t) for t in args.taus.split(",")]
    refs = [] if args.no_shipped else list(worlds.list_worlds())
    refs += [f"{k}:{s}" for k in args.kinds.split(",") if k for s in _seeds(args.seeds)]
    shifts = [float(v) for v in args.shifts.split(",") if v]
    # a world's jobs side by side: each worker generates it once (lru_cache)
    jobs = [job for r in refs for job in [(r, d, 0.0, taus) for d in range(args.draws)]
            + [(r, 0, sh, taus) for sh in shifts if sh]]
    with ProcessPoolExecutor(args.jobs) as ex:
        rows = list(ex.map(_job, jobs))
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=1))
    base = [r for r in rows if r["shift"] == 0.0]
    print("| world | cell P | cell S | " + " | ".join(f"surface P/S tau {t:g}" for t in taus)
          + " | moved one cell P/S (tau " + f"{taus[len(taus) // 2]:g}) |")
    print("|---" * (4 + len(taus)) + "|")
    mid = f"{taus[len(taus) // 2]:g}"
    for ref in refs:
        rs = [r for r in base if r["ref"] == ref]
        cells = [f"{np.mean([r['cell_p'] for r in rs]):.3f}", f"{np.mean([r['cell_s'] for r in rs]):.3f}"]
        for t in taus:
            cells.append(f"{np.mean([r[f'p_{t:g}'] for r in rs]):.3f} / {np.mean([r[f's_{t:g}'] for r in rs]):.3f}")
        mp = np.mean([r[f"moved{d}_p_{mid}"] for r in rs for d in ("+x", "-x", "+y", "-y")])
        ms = np.mean([r[f"moved{d}_s_{mid}"] for r in rs for d in ("+x", "-x", "+y", "-y")])
        cells.append(f"{mp:.3f} / {ms:.3f}")
        print(f"| {rs[0]['world']} | " + " | ".join(cells) + " |")
    print()
    print("| tau (m) | min oracle P | min oracle S | logs with P or S < 0.95 | mean moved P | "
          "mean moved S | perfect map P / S (min) |")
    print("|---|---|---|---|---|---|---|")
    for t in taus:
        p = [r[f"p_{t:g}"] for r in base]
        s = [r[f"s_{t:g}"] for r in base]
        bad = sum(1 for a, b in zip(p, s) if min(a, b) < 0.95)
        mp = np.mean([r[f"moved{d}_p_{t:g}"] for r in base for d in ("+x", "-x", "+y", "-y")])
        ms = np.mean([r[f"moved{d}_s_{t:g}"] for r in base for d in ("+x", "-x", "+y", "-y")])
        print(f"| {t:g} | {min(p):.3f} | {min(s):.3f} | {bad}/{len(base)} | {mp:.3f} | {ms:.3f} | "
              f"{min(r['truth_p'] for r in base):.3f} / {min(r['truth_s'] for r in base):.3f} |")
    if shifts:
        print()
        print("| world | " + " | ".join(f"shift {v:g} m P / S (tau {mid})" for v in [0.0] + shifts)
              + " | largest change |")
        print("|---" * (len(shifts) + 3) + "|")
        worst = 0.0
        for ref in refs:
            rs = {r["shift"]: r for r in rows if r["ref"] == ref and r["draw"] == 0}
            vals = [(rs[v][f"p_{mid}"], rs[v][f"s_{mid}"]) for v in [0.0] + shifts]
            change = max(max(abs(a - vals[0][0]), abs(b - vals[0][1])) for a, b in vals)
            worst = max(worst, change)
            print(f"| {rs[0.0]['world']} | " + " | ".join(f"{a:.3f} / {b:.3f}" for a, b in vals)
                  + f" | {change:.3f} |")
        print(f"\nlargest change over all worlds: {worst:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
