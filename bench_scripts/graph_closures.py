"""Loop-closure candidates of `graph` scored against the true poses, and what the see-through
check makes of them.

    python bench_scripts/graph_closures.py --logs DIR [--worlds a,b] [--set key.path=value]
                                           [--oracle-filter M,DEG]

DIR holds WORLD.npz logs from `python -m sim record` (simulated: they carry the true path).
`graph` runs with the see-through check switched off, so every match that passes min_score, the
ambiguity and the information tests is seen. Each is compared, after the run, with the true pose
of its node relative to the member node of its submap nearest to it (the local SLAM places a
node in its own submap to a few millimetres, so this is the submap's frame up to that), and
its see-through ratio (slam.graph.loop_closure.see_through_ratio) is computed at the matched
pose. Printed per world: matches within --good m of the truth and between --false-min and
--false-max m, how many of each the configured check (max_see_through_ratio,
see_through_free_probability of the config) rejects, and the median |dx|, |dy| (world frame)
of the false ones. Evaluation only: the algorithm never sees the true path.

--oracle-filter M,DEG instead runs `graph` as configured (check included) but keeps only the
loop closures within M metres and DEG degrees of the truth, and prints precision,
sensitivity, ATE and end-of-run error: what the pose graph makes of closures that precise
(a ceiling for the loop-closure search, as the oracle algorithm is for the poses).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from worlds.yamlio import set_override  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--logs", required=True, help="folder of WORLD.npz sensor logs")
    ap.add_argument("--worlds", default=None, help="comma-separated world names (default: all)")
    ap.add_argument("--set", action="append", default=[], help="config override key.path=value")
    ap.add_argument("--good", type=float, default=0.04, help="m: a match this close is good")
    ap.add_argument("--false-min", type=float, default=0.06, help="m: false matches from here")
    ap.add_argument("--false-max", type=float, default=0.30, help="m: ... up to here")
    ap.add_argument("--oracle-filter", default=None, metavar="M,DEG",
                    help="keep only closures this close to the truth and score the run")
    args = ap.parse_args(argv)

    from sim.log import read_log
    from slam.base import load_config, run
    from slam.graph import GraphSlam
    cfg: dict = {}
    for s in args.set:
        set_override(cfg, s)
    checked = load_config("graph", cfg).pose_graph.constraint_builder
    if args.oracle_filter:
        trans, rot = (float(v) for v in args.oracle_filter.split(","))
        return _oracle_filtered(args, cfg, trans, rot)
    set_override(cfg, "pose_graph.constraint_builder.max_see_through_ratio=0")
    logs = _logs(args)
    print(f"see-through check: more than {checked.max_see_through_ratio} of the points, "
          f"p < {checked.see_through_free_probability}")
    print(f"{'world':12s} {'matches':>7s} {'good':>5s} {'rejected':>8s} {'false':>5s} {'rejected':>8s} "
          f"{'false |dx|, |dy| (m)':>21s}")
    for p in logs:
        log = read_log(p)
        slam = GraphSlam(load_config("graph", cfg), log.start_pose.copy(), np.random.default_rng(0))
        found = _record_matches(slam, checked.see_through_free_probability)
        run(slam, log)
        err, dxy, ratio = _score(slam, log, found)
        good, false = err < args.good, (err >= args.false_min) & (err <= args.false_max)
        rejected = ratio > checked.max_see_through_ratio
        med = np.median(np.abs(dxy[false]), axis=0) if false.any() else np.full(2, np.nan)
        print(f"{p.stem:12s} {len(err):7d} {good.sum():5d} {(good & rejected).sum():8d} {false.sum():5d} "
              f"{(false & rejected).sum():8d} {med[0]:10.3f}, {med[1]:.3f}", flush=True)
    return 0


def _logs(args) -> list[Path]:
    """The WORLD.npz logs of --logs, only those of --worlds when given."""
    logs = sorted(Path(args.logs).glob("*.npz"))
    return [p for p in logs if p.stem in args.worlds.split(",")] if args.worlds else logs


def _record_matches(slam, free_probability: float) -> list:
    """Wrap the slam's constraint builder: keep (constraint, see-through ratio) of every match."""
    from slam.graph.loop_closure import see_through_ratio
    from slam.pose import compose
    builder = slam.graph.builder
    compute = builder.compute
    found = []

    def recording(submap, submap_global, node, node_global, points, origin):
        c = compute(submap, submap_global, node, node_global, points, origin)
        if c is not None:
            pose = compose(submap.local_pose, c.z)
            found.append((c, see_through_ratio(submap, points, origin, pose, free_probability)))
        return c

    builder.compute = recording
    return found


def _closure_error(slam, true: np.ndarray, node_scan: dict, c) -> tuple[np.ndarray, float]:
    """(dx, dy, dyaw) of closure c against the truth, (dx, dy) turned into the world frame,
    relative to the member node of its submap nearest to it; and the translation error (m)."""
    from slam.pose import relative
    at = true[node_scan[c.node]]
    members = [n for n, subs in enumerate(slam.graph.node_submaps) if c.submap in subs]
    m = min(members, key=lambda k: np.hypot(*(true[node_scan[k]][:2] - at[:2])))
    z_m = relative(slam.local.submaps.all[c.submap].local_pose, slam.graph.node_local[m])
    d = relative(z_m, c.z) - relative(true[node_scan[m]], at)
    yaw = true[node_scan[m]][2]
    d[:2] = [np.cos(yaw) * d[0] - np.sin(yaw) * d[1], np.sin(yaw) * d[0] + np.cos(yaw) * d[1]]
    d[2] = (d[2] + np.pi) % (2 * np.pi) - np.pi
    return d, float(np.hypot(d[0], d[1]))


def _score(slam, log, found):
    """Per match: translation error (m) against the truth, its (dx, dy) world frame, ratio."""
    from slam.pose import interpolate_poses
    true = interpolate_poses(log.scan_t, log.gt_t, log.gt_pose)
    node_scan: dict[int, int] = {}
    for i, k in enumerate(slam.scan_node):
        node_scan.setdefault(k, i)
    err, dxy, ratio = [], [], []
    for c, r in found:
        d, e = _closure_error(slam, true, node_scan, c)
        dxy.append(d[:2])
        err.append(e)
        ratio.append(r)
    return np.array(err), np.array(dxy).reshape(-1, 2), np.array(ratio)


def _oracle_filtered(args, cfg: dict, trans: float, rot_deg: float) -> int:
    """Run graph keeping only the closures within trans m and rot_deg degrees of the truth."""
    from metrics import score_map, trajectory_error
    from sim.log import read_log
    from slam.base import load_config, run
    from slam.graph import GraphSlam
    from slam.pose import interpolate_poses
    from worlds import load_world, rasterize
    logs = _logs(args)
    print(f"closures kept within {trans} m and {rot_deg} deg of the truth")
    print(f"{'world':12s} {'P':>6s} {'S':>6s} {'ATE':>7s} {'end':>7s} kept/found")
    for p in logs:
        log = read_log(p)
        true = interpolate_poses(log.scan_t, log.gt_t, log.gt_pose)
        slam = GraphSlam(load_config("graph", cfg), log.start_pose.copy(), np.random.default_rng(0))
        node_scan: dict[int, int] = {}
        add_node, compute = slam.graph.add_node, slam.graph.builder.compute
        counts = [0, 0]

        def add_node_at_scan(*a, **k):
            node_scan[len(slam.graph.node_local)] = len(slam.times)   # the scan being processed
            return add_node(*a, **k)

        def filtered(submap, submap_global, node, node_global, points, origin):
            c = compute(submap, submap_global, node, node_global, points, origin)
            if c is None:
                return None
            counts[1] += 1
            d, e = _closure_error(slam, true, node_scan, c)
            if e > trans or np.degrees(abs(d[2])) > rot_deg:
                return None
            counts[0] += 1
            return c

        slam.graph.add_node, slam.graph.builder.compute = add_node_at_scan, filtered
        r = run(slam, log)
        m = score_map(r.grid, rasterize(load_world(p.stem)), initial=(0.0, 0.0, 0.0), gtfree=False)
        te = trajectory_error(r.times, r.poses, log.gt_t, log.gt_pose)
        end = float(np.hypot(*(r.poses[-1, :2] - true[-1, :2])))
        print(f"{p.stem:12s} {m['precision']:6.3f} {m['sensitivity']:6.3f} {te['ate_m']:7.4f} {end:7.4f} "
              f"{counts[0]}/{counts[1]}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
