"""The output map and the surface form on the oracle's maps: the checks of docs/metrics.md.

    python tools/surface_metric.py [--seeds 0-9] [--shift-seeds 0-2] [--draws 3]
        [--kinds office,warehouse,hall,loop] [--tau M] [--jobs 2] [--out FILE.json]
    python tools/surface_metric.py --time [--runs 7]     # output map of swirl_l's log

Records each world's log (realistic profile, log seeds 0 .. draws-1), maps it with the oracle
(true poses) and scores it as `bench` does (ICP alignment from identity), at tau = --tau
(default: metrics.surface.DEFAULT_TAU_M). Worlds: every shipped world and the generated worlds
of each kind with generator seeds --seeds. Then, on the shipped worlds and the generated seeds
--shift-seeds, draw 0:
 - shift: the whole world moved by 0.01, 0.025 and 0.04 m (log re-recorded), oracle re-scored;
 - moved: the oracle's map moved diagonally by one cell, scored with no alignment;
 - drift: maps built from the true trajectory plus a smooth drift of 1, 2, 3.5 and 5 cm
   (mean F1 over three shapes of each), which must score lower at each step; how the 1 cm
   map compares with the oracle's is printed beside the checks, not checked (on a wall whose
   face lies in the middle of its cell, 1 cm moves nothing out of the cell);
 - turned: maps built from the true trajectory turned rigidly about its centroid by 1, 3 and
   5 mrad, F1 under the benchmark's alignment and under the exact inverse turn (what a perfect
   alignment would score): a map that is the truth moved rigidly must score as the truth does;
and the far-walls world (tests/data/far_walls.yaml: a route 2.5 m from two long walls).
Prints markdown tables and a PASS / FAIL line per check (the numbers in CHECKS); exits 1 if
one fails. --out writes every number as JSON.
"""
from __future__ import annotations

import argparse
import functools
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SHIFTS = (0.01, 0.025, 0.04)
DRIFTS = (0.01, 0.02, 0.035, 0.05)
DRIFT_PHASES = (0.0, 2 * np.pi / 3, 4 * np.pi / 3)   # a drift's score: the mean F1 of three shapes
TURNS = (0.001, 0.003, 0.005)   # rad: rigid turns of the true trajectory
OTHER_TAUS = (0.0075, 0.01)     # the oracle's base scores at these too, to compare taus
FAR_WALLS = ROOT / "tests" / "data" / "far_walls.yaml"
# the done-when numbers: oracle P and S on every map and on average, the change under a
# world shift, the one-cell move's mean, the far-walls world's sensitivity and its coverage;
# and how far a turned map's F1 may fall from its score under the exact inverse turn
CHECKS = {"oracle_min": 0.95, "oracle_mean": 0.97, "shift_max": 0.02, "moved_mean": 0.25,
          "far_sensitivity": 0.93, "far_coverage": 0.95, "turned_max": 0.01}


def _seeds(text: str) -> list[int]:
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(t) for t in text.split(",") if t]


@functools.lru_cache(maxsize=4)
def _world_json(ref: str) -> str:
    """World YAML data (as JSON) of a shipped world name, 'kind:seed' or a YAML path."""
    from worlds.generate import generate_world
    from worlds.load import world_dir
    from worlds.yamlio import load_yaml
    if ref.endswith(".yaml"):
        return json.dumps(load_yaml(Path(ref)))
    if ":" in ref:
        kind, seed = ref.split(":")
        return json.dumps(generate_world(kind, int(seed)))
    return json.dumps(load_yaml(world_dir() / f"{ref}.yaml"))


def shifted(data: dict, dx: float, dy: float) -> dict:
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


def smooth_drift(times: np.ndarray, amplitude: float, phase: float = 0.0) -> np.ndarray:
    """(N, 2) m: a drift that wanders smoothly over the log (one slow period in x, a phase-
    shifted one in y, starting at `phase` rad) with components of `amplitude` m at most; its
    mean over the log is near zero, so the alignment cannot take it out."""
    u = 2 * np.pi * (times - times[0]) / max(times[-1] - times[0], 1e-9) + phase
    return amplitude * np.stack([np.sin(u), np.sin(u + 2.0)], axis=1)


def turn_about_centroid(poses: np.ndarray, angle: float) -> np.ndarray:
    """(3,) the rigid transform that turns poses (N, 3) by `angle` rad about the centroid of
    their positions."""
    cx, cy = poses[:, :2].mean(axis=0)
    c, s = np.cos(angle), np.sin(angle)
    return np.array([cx - (c * cx - s * cy), cy - (s * cx + c * cy), angle])


def _bench_score(grid, world, truth, tau):
    """(surface P, S, study cell P, S) as bench scores a simulated world's map (both forms
    under one ICP alignment from identity)."""
    import metrics
    from metrics.surface import visible_surfaces
    s = metrics.score_map(grid, truth, align="auto", initial=(0.0, 0.0, 0.0), gtfree=False,
                          surfaces=visible_surfaces(world), tau_m=tau)
    return s["surface_precision"], s["surface_sensitivity"], s["precision"], s["sensitivity"]


def _job(args):
    """One world and draw: the oracle's scores; with extras, the moved map, the drifts and the
    turns."""
    ref, log_seed, shift, tau, extras = args
    import sim
    from metrics.surface import classify_surface, visible_surfaces
    from slam.output_map import OutputMapConfig, output_map_from_trajectory
    from slam.pose import compose, inverse
    from slam.replay import run_algorithm, scans_of
    from worlds import rasterize
    from worlds.grid import Grid
    from worlds.load import world_from_dict
    data = json.loads(_world_json(ref))
    if shift:
        data = shifted(data, shift, shift)
    world = world_from_dict(data, where=str(data.get("name", ref)))
    log = sim.record(world, seed=log_seed, noise="realistic")
    oracle = run_algorithm("oracle", log, seed=0)
    truth = rasterize(world)
    p, s, cp, cs = _bench_score(oracle.grid, world, truth, tau)
    row = {"world": world.name, "ref": ref, "draw": log_seed, "shift": shift, "p": p, "s": s,
           "cell_p": cp, "cell_s": cs, "coverage": log.meta.get("wall_coverage")}
    for other in OTHER_TAUS:
        row[f"p_{other:g}"], row[f"s_{other:g}"], _, _ = _bench_score(oracle.grid, world, truth, other)
    if extras:
        g = oracle.grid
        surfaces = visible_surfaces(world)
        moved = Grid(g.prob, g.resolution, g.origin + [g.resolution, g.resolution, 0.0])
        c = classify_surface(moved, surfaces, (0.0, 0.0, 0.0), tau).portion
        row["moved_p"], row["moved_s"] = c.surface_precision, c.surface_sensitivity
        scans = scans_of(log)
        for amp in DRIFTS:
            f1 = []
            for phase in DRIFT_PHASES:
                poses = oracle.poses.copy()
                poses[:, :2] += smooth_drift(oracle.times, amp, phase)
                grid = output_map_from_trajectory(OutputMapConfig(), scans, oracle.times, poses)
                f1.append(_f1(*_bench_score(grid, world, truth, tau)[:2]))
            row[f"drift_{amp:g}"] = float(np.mean(f1))
        for angle in TURNS:
            turn = turn_about_centroid(oracle.poses, angle)
            grid = output_map_from_trajectory(OutputMapConfig(), scans, oracle.times,
                                              compose(turn, oracle.poses))
            row[f"turn_{angle:g}"] = _f1(*_bench_score(grid, world, truth, tau)[:2])
            c = classify_surface(grid, surfaces, inverse(turn), tau).portion
            row[f"turn_exact_{angle:g}"] = _f1(c.surface_precision, c.surface_sensitivity)
    return row


def checks(rows: list[dict]) -> list[tuple[str, bool, str]]:
    """(name, passed, numbers) of each done-when check the rows cover."""
    out = []
    base = [r for r in rows if r["shift"] == 0.0 and r["ref"] != str(FAR_WALLS)]
    if base:
        worst = min(min(r["p"], r["s"]) for r in base)
        mean_p, mean_s = np.mean([r["p"] for r in base]), np.mean([r["s"] for r in base])
        out.append(("oracle P and S on every map", worst >= CHECKS["oracle_min"],
                    f"min {worst:.3f} over {len(base)} maps (>= {CHECKS['oracle_min']})"))
        out.append(("oracle P and S on average", min(mean_p, mean_s) >= CHECKS["oracle_mean"],
                    f"P {mean_p:.3f}, S {mean_s:.3f} (>= {CHECKS['oracle_mean']})"))
    shifted_rows = [r for r in rows if r["shift"]]
    if shifted_rows:
        ref0 = {(r["ref"], r["draw"]): r for r in base}
        change = max(max(abs(r["p"] - ref0[(r["ref"], 0)]["p"]), abs(r["s"] - ref0[(r["ref"], 0)]["s"]))
                     for r in shifted_rows)
        out.append(("world shift moves P and S", change <= CHECKS["shift_max"],
                    f"largest change {change:.4f} (<= {CHECKS['shift_max']})"))
    extra = [r for r in base if "moved_p" in r]
    if extra:
        mp, ms = np.mean([r["moved_p"] for r in extra]), np.mean([r["moved_s"] for r in extra])
        out.append(("map moved one cell diagonally, no alignment", max(mp, ms) <= CHECKS["moved_mean"],
                    f"mean P {mp:.3f}, S {ms:.3f} over {len(extra)} maps (<= {CHECKS['moved_mean']})"))
        bad = [r["world"] for r in extra if not _falls([r[f"drift_{a:g}"] for a in DRIFTS])]
        out.append(("drift maps score lower at each step (F1)", not bad,
                    f"{len(extra) - len(bad)}/{len(extra)} worlds fall from 1 to 2, 3.5 and 5 cm"
                    + (f"; not: {bad}" if bad else "")))
        loss = max(r[f"turn_exact_{a:g}"] - r[f"turn_{a:g}"] for r in extra for a in TURNS)
        out.append(("turned maps score as under the exact inverse turn", loss <= CHECKS["turned_max"],
                    f"largest F1 loss {loss:.4f} over {len(extra)} worlds x {len(TURNS)} turns "
                    f"(<= {CHECKS['turned_max']})"))
    far = [r for r in rows if r["ref"] == str(FAR_WALLS)]
    if far:
        cov, s = min(r["coverage"] for r in far), min(r["s"] for r in far)
        out.append(("far walls: coverage check passes", cov >= CHECKS["far_coverage"],
                    f"coverage {cov:.3f} (>= {CHECKS['far_coverage']})"))
        out.append(("far walls: oracle sensitivity", s >= CHECKS["far_sensitivity"],
                    f"S {s:.3f} (>= {CHECKS['far_sensitivity']})"))
    return out


def _f1(p, s):
    return 2 * p * s / (p + s) if p + s > 0 else 0.0


def _falls(values) -> bool:
    return all(b < a for a, b in zip(values, values[1:]))


def first_drift_step(rows: list[dict]) -> str:
    """The oracle's map against the 1 cm drift map (not a check: where a wall's face lies in
    the middle of its cell, 1 cm moves none out of it, and a map of cells cannot change)."""
    extra = [r for r in rows if r["shift"] == 0.0 and "moved_p" in r]
    same = [f"{r['world']} {r['drift_0.01'] - _f1(r['p'], r['s']):+.4f}" for r in extra
            if not r["drift_0.01"] < _f1(r["p"], r["s"])]
    return (f"the 1 cm drift map scores below the oracle's on {len(extra) - len(same)}/{len(extra)} worlds"
            + (f"; not (F1 change): {', '.join(same)}" if same else ""))


def run(refs, shift_refs, draws, tau, jobs=2):
    """Every row: refs x draws, the shifts and extras of shift_refs, the far-walls world."""
    tasks = [(r, d, 0.0, tau, r in shift_refs and d == 0) for r in refs for d in range(draws)]
    tasks += [(r, 0, sh, tau, False) for r in shift_refs for sh in SHIFTS]
    tasks += [(str(FAR_WALLS), d, 0.0, tau, False) for d in range(draws)]
    if jobs <= 1:
        return [_job(t) for t in tasks]
    with ProcessPoolExecutor(jobs) as ex:
        return list(ex.map(_job, tasks))


def print_tables(rows, tau):
    base = [r for r in rows if r["shift"] == 0.0]
    print(f"| world | maps | surface P (tau {tau:g} m) | surface S | study's cell P | cell S |")
    print("|---|---|---|---|---|---|")
    for ref in dict.fromkeys(r["ref"] for r in base):
        rs = [r for r in base if r["ref"] == ref]
        cells = [f"{np.mean([r[k] for r in rs]):.3f} ± {np.std([r[k] for r in rs]):.3f}"
                 for k in ("p", "s", "cell_p", "cell_s")]
        print(f"| {rs[0]['world']} | {len(rs)} | " + " | ".join(cells) + " |")
    extra = [r for r in base if "moved_p" in r]
    if extra:
        print("\n| world | shift 0.01 / 0.025 / 0.04 m: P, S | moved one cell: P / S | "
              "drift 0 / 1 / 2 / 3.5 / 5 cm: F1 (mean of 3 shapes) | turned "
              + " / ".join(f"{a * 1e3:g}" for a in TURNS) + " mrad: F1 aligned (exact) |")
        print("|---|---|---|---|---|")
        for r in extra:
            sh = [x for x in rows if x["ref"] == r["ref"] and x["shift"]]
            shs = ", ".join(f"{x['p']:.3f} {x['s']:.3f}" for x in sorted(sh, key=lambda x: x["shift"]))
            f1 = [_f1(r["p"], r["s"])] + [r[f"drift_{a:g}"] for a in DRIFTS]
            turned = " / ".join(f"{r[f'turn_{a:g}']:.3f} ({r[f'turn_exact_{a:g}']:.3f})"
                                for a in TURNS)
            print(f"| {r['world']} | {shs} | {r['moved_p']:.3f} / {r['moved_s']:.3f} | "
                  + " / ".join(f"{v:.3f}" for v in f1) + f" | {turned} |")
    print()
    ok = True
    for name, passed, detail in checks(rows):
        ok &= passed
        print(f"{'PASS' if passed else 'FAIL'}: {name}: {detail}")
    if extra:
        print(f"Not a check: {first_drift_step(rows)}")
    return ok


def time_output_map(runs: int) -> int:
    """Median wall time of building the output map of swirl_l's log (seed 0) from its true
    trajectory, the kernels compiled first."""
    import sim
    import worlds
    from slam.output_map import OutputMapConfig, output_map_from_trajectory
    from slam.replay import run_algorithm, scans_of
    log = sim.record(worlds.load_world("swirl_l"), seed=0, noise="realistic")
    oracle = run_algorithm("oracle", log)
    scans = scans_of(log)
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        grid = output_map_from_trajectory(OutputMapConfig(), scans, oracle.times, oracle.poses)
        times.append(time.perf_counter() - t0)
    print(f"swirl_l: {log.n_scans} scans ({log.duration:.0f} s of log), map {grid.rows} x "
          f"{grid.cols} cells: output map median {np.median(times):.3f} s (min {min(times):.3f}, "
          f"max {max(times):.3f}) over {runs} runs")
    return 0


def main(argv=None) -> int:
    from metrics.surface import DEFAULT_TAU_M
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-9")
    ap.add_argument("--shift-seeds", default="0-2")
    ap.add_argument("--kinds", default="office,warehouse,hall,loop")
    ap.add_argument("--draws", type=int, default=3)
    ap.add_argument("--tau", type=float, default=DEFAULT_TAU_M)
    ap.add_argument("--no-shipped", action="store_true")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=None)
    ap.add_argument("--time", action="store_true", help="only time the output map of swirl_l")
    ap.add_argument("--runs", type=int, default=7)
    args = ap.parse_args(argv)
    if args.time:
        return time_output_map(args.runs)
    import worlds
    shipped = [] if args.no_shipped else list(worlds.list_worlds())
    kinds = [k for k in args.kinds.split(",") if k]
    refs = shipped + [f"{k}:{s}" for k in kinds for s in _seeds(args.seeds)]
    shift_refs = shipped + [f"{k}:{s}" for k in kinds for s in _seeds(args.shift_seeds)]
    rows = run(refs, shift_refs, args.draws, args.tau, args.jobs)
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=1))
    return 0 if print_tables(rows, args.tau) else 1


if __name__ == "__main__":
    sys.exit(main())
