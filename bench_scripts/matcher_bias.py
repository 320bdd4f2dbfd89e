"""Bias of `graph`'s local scan matcher: where does a scan land when matched from its true pose?

    python bench_scripts/matcher_bias.py --logs DIR [--worlds a,b] [--config YAML] [--set key=value]
                                         [--map-logs DIR2]

A diagnostic that reads the ground truth on purpose (no SLAM run does). For each log, the
local SLAM's submaps are built from the scans at their true poses (motion filter, voxel
filters and submap options of the configuration); each scan is matched against the matching
submap by the same least squares, started at its true pose with weak priors (translation
and rotation weights 1), and its error in the robot frame (forward, left, heading) is
collected. Mean and standard deviation per world are printed: a mean that is not zero is a
bias, which the local SLAM adds up along the route and loop closures carry into the graph.

--map-logs DIR2 builds the submaps from DIR2's logs of the same worlds and seed instead (same
route, other noise profile: e.g. noise-free submaps with noisy scans) to tell the bias of
the submaps from that of the scans.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def matcher_errors(log, cfg, map_log=None) -> np.ndarray:
    """(K, 3) forward, left (m), heading (rad) errors of the matches of `log`'s scans."""
    from slam.base import _iter_inputs
    from slam.graph.config import CeresScanMatcherConfig
    from slam.graph.local import LocalSlam
    from slam.graph.scan_matching import ceres_match
    from slam.pose import interpolate_poses, relative, transform_points, wrap_angle
    from slam.preprocess import twist_from_poses

    tb = cfg.trajectory_builder
    local = LocalSlam(tb, log.start_pose)
    truth = interpolate_poses(log.scan_t, log.gt_t, log.gt_pose)
    weak = CeresScanMatcherConfig(occupied_space_weight=tb.ceres_scan_matcher.occupied_space_weight,
                                  translation_weight=1.0, rotation_weight=1.0,
                                  max_num_iterations=tb.ceres_scan_matcher.max_num_iterations)
    map_scans = [s for s, *_ in _iter_inputs(map_log)] if map_log is not None else None
    errors = []
    for i, (scan, _, _, _) in enumerate(_iter_inputs(log)):
        pose = truth[i]
        twist = twist_from_poses(truth[i - 1], pose, scan.t - log.scan_t[i - 1]) if i else np.zeros(3)
        sp, hits, points = local.filter_scan(scan, twist)
        sub = local.submaps.matching_submap()
        if sub is not None and sub.num_range_data >= 20 and len(points) >= 3:
            prob, meta = sub.probabilities()
            w = local.match_weights(sub, points, pose)
            d = relative(pose, ceres_match(prob, meta, points, pose, pose, weak, w))
            errors.append([d[0], d[1], wrap_angle(d[2])])
        if local.motion_filter.is_similar(scan.t, pose):
            continue
        if map_scans is not None:
            sp, hits, _ = local.filter_scan(map_scans[i], twist)
        local.submaps.insert(transform_points(pose, sp.origin[None, :])[0], transform_points(pose, hits),
                             transform_points(pose, sp.misses))
    return np.array(errors).reshape(-1, 3)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", required=True)
    ap.add_argument("--map-logs", default=None)
    ap.add_argument("--worlds", default="")
    ap.add_argument("--config", default=None)
    ap.add_argument("--set", action="append", default=[])
    args = ap.parse_args(argv)
    import yaml
    from sim.log import read_log
    from slam.base import _ensure_builtin_algorithms, load_config
    from worlds.yamlio import set_override
    _ensure_builtin_algorithms()
    raw = yaml.safe_load(Path(args.config).read_text()) if args.config else {}
    for s in args.set:
        set_override(raw, s)
    cfg = load_config("graph", raw)
    logs = sorted(Path(args.logs).glob("*.npz"))
    if args.worlds:
        logs = [p for p in logs if p.stem in args.worlds.split(",")]
    print(f"{'world':12s} {'forward mm':>14s} {'left mm':>14s} {'heading mdeg':>16s}  matches")
    for p in logs:
        map_log = read_log(Path(args.map_logs) / p.name) if args.map_logs else None
        e = matcher_errors(read_log(p), cfg, map_log)
        fwd, left, head = e[:, 0] * 1e3, e[:, 1] * 1e3, np.degrees(e[:, 2]) * 1e3
        print(f"{p.stem:12s} {fwd.mean():+7.1f} +-{fwd.std():4.0f} {left.mean():+7.1f} +-{left.std():4.0f} "
              f"{head.mean():+8.0f} +-{head.std():5.0f}  {len(e)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
