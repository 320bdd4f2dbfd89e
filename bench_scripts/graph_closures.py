"""Loop-closure candidates of `graph` scored against the true poses, and what the see-through
check makes of them.

    python bench_scripts/graph_closures.py --logs DIR [--worlds a,b] [--set key.path=value]

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
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from graph_speed import _set  # noqa: E402  (same --set syntax)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--logs", required=True, help="folder of WORLD.npz sensor logs")
    ap.add_argument("--worlds", default=None, help="comma-separated world names (default: all)")
    ap.add_argument("--set", action="append", default=[], help="config override key.path=value")
    ap.add_argument("--good", type=float, default=0.04, help="m: a match this close is good")
    ap.add_argument("--false-min", type=float, default=0.06, help="m: false matches from here")
    ap.add_argument("--false-max", type=float, default=0.30, help="m: ... up to here")
    args = ap.parse_args(argv)

    from sim.log import read_log
    from slam.base import load_config, run
    from slam.graph import GraphSlam
    cfg: dict = {}
    for s in args.set:
        _set(cfg, s)
    checked = load_config("graph", cfg).pose_graph.constraint_builder
    _set(cfg, "pose_graph.constraint_builder.max_see_through_ratio=0")
    logs = sorted(Path(args.logs).glob("*.npz"))
    if args.worlds:
        logs = [p for p in logs if p.stem in args.worlds.split(",")]
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


def _score(slam, log, found):
    """Per match: translation error (m) against the truth, its (dx, dy) world frame, ratio."""
    from slam.pose import interpolate_poses, relative
    true = interpolate_poses(log.scan_t, log.gt_t, log.gt_pose)
    node_scan: dict[int, int] = {}
    for i, k in enumerate(slam.scan_node):
        node_scan.setdefault(k, i)
    local = np.array(slam.graph.node_local)
    members: dict[int, list[int]] = {}
    for n, subs in enumerate(slam.graph.node_submaps):
        for s in subs:
            members.setdefault(s, []).append(n)
    err, dxy, ratio = [], [], []
    for c, r in found:
        at = true[node_scan[c.node]]
        m = min(members[c.submap], key=lambda k: np.hypot(*(true[node_scan[k]][:2] - at[:2])))
        z_m = relative(slam.local.submaps.all[c.submap].local_pose, local[m])
        d = relative(z_m, c.z) - relative(true[node_scan[m]], at)
        yaw = true[node_scan[m]][2]
        dxy.append([np.cos(yaw) * d[0] - np.sin(yaw) * d[1], np.sin(yaw) * d[0] + np.cos(yaw) * d[1]])
        err.append(np.hypot(d[0], d[1]))
        ratio.append(r)
    return np.array(err), np.array(dxy).reshape(-1, 2), np.array(ratio)


if __name__ == "__main__":
    sys.exit(main())
