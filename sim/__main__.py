"""Command line: python -m sim record | show | lidars | import | export  (see --help of each).

Exit codes: 0 done; 2 bad input (one line on stderr); 3 (`record`) the log was written but
cannot be trusted: the robot got stuck, the time limit ran out, or the log saw too little of
the walls (a warning line on stderr says which).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from worlds.cli import Parser, check_out_file, non_negative_int, run_cli, share_0_1
from worlds.yamlio import InputError

# `record` wrote the log, but it did not finish its route or did not cover the walls
EXIT_UNTRUSTED_LOG = 3


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="python -m sim", description="Simulate a TurtleBot3-like robot "
               "and record sensor logs.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("record", help="drive a world's route and write a sensor log (.npz)")
    r.add_argument("--world", required=True, help="world name (python -m worlds list) or YAML file")
    r.add_argument("--seed", type=non_negative_int, default=0, help="non-negative integer (default 0)")
    r.add_argument("--out", required=True, help="output .npz")
    r.add_argument("--noise", default="realistic", help="profile name (ideal, gazebo, realistic) "
                   "or YAML file (default: realistic)")
    r.add_argument("--config", default=None, help="RecordConfig YAML (rates, lidar, controller, robot)")
    r.add_argument("--lidar", default=None, metavar="NAME|FILE",
                   help="lidar from the catalogue (python -m sim lidars) or a lidar YAML file "
                        "(default: the config's, the LDS-01)")
    r.add_argument("--min-coverage", type=share_0_1, default=None, metavar="SHARE",
                   help="warn and exit 3 when the log's lidar saw less than this share of the "
                        "true wall cells (default 0.95)")
    s = sub.add_parser("show", help="draw the true and odometry paths of a log over its world")
    s.add_argument("log")
    s.add_argument("--out", default=None, help="PNG file (default: LOG with .png)")
    i = sub.add_parser("import", help="convert a robot log (CARMEN, gfs, ROS 1 bag, ROS 2 bag, "
                                      "MCAP) to a sensor log")
    i.add_argument("file", help="log file, .bag, .mcap, or a ROS 2 bag folder")
    i.add_argument("--out", required=True, help="output .npz")
    i.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    i.add_argument("--format", choices=["carmen", "gfs"], default=None,
                   help="text log format (default: guessed from the file)")
    i.add_argument("--topic", "--scan-topic", dest="scan_topic",
                   help="bags: LaserScan or MultiEchoLaserScan topic (default /scan, else the "
                        "first by name, with a warning when there are several)")
    i.add_argument("--odom-topic", help="bags: nav_msgs/Odometry topic (default /odom, else /tf)")
    i.add_argument("--imu-topic", help="bags: sensor_msgs/Imu topic (default /imu)")
    sub.add_parser("lidars", help="list the lidar catalogue")
    e = sub.add_parser("export", help="write a sensor log as a ROS bag (needs pip install .[ros])")
    e.add_argument("log", help="sensor log (.npz)")
    e.add_argument("--format", required=True, choices=["ros1", "ros2", "mcap"])
    e.add_argument("--out", required=True, help="ros1: a .bag file; ros2, mcap: a bag folder")
    e.add_argument("--epoch", type=non_negative_int, default=None, metavar="SECONDS",
                   help="stamp of the log's time 0, whole seconds since 1970 "
                        "(default 1700000000, 2023-11-14 22:13:20 UTC)")
    return p


def _load_world(name_or_path: str):
    from worlds import load_world
    return load_world(name_or_path)


def _log_world(log, log_path: str):
    """The World of a recorded log (sim.logs.world_ref), or None: unknown or unreadable."""
    from sim.logs import world_ref
    ref = world_ref(log.meta, log_path)
    if ref is None:
        return None
    try:
        return _load_world(ref)
    except (InputError, OSError):
        return None


def cmd_record(args) -> int:
    from sim import MIN_COVERAGE, record, recording_problem, write_log
    min_cover = MIN_COVERAGE if args.min_coverage is None else args.min_coverage
    check_out_file(args.out)
    world = _load_world(args.world)
    log = record(world, seed=args.seed, noise=args.noise, config=args.config, lidar=args.lidar)
    write_log(log, args.out)
    d = log.meta["odometry_drift"]
    print(f"{args.out}: {log.n_scans} scans, {log.gt_t[-1]:.1f} s, {d['distance']:.1f} m driven, "
          f"ended: {log.meta['ending']}, walls seen {100 * log.meta['wall_coverage']:.1f} %, "
          f"odometry drift {100 * d['segment_drift']:.1f} % per {d['segment']:.0f} m")
    problem = recording_problem(log.meta, min_cover)
    if problem:
        print(f"warning: {args.out}: {problem}", file=sys.stderr)
        return EXIT_UNTRUSTED_LOG
    return 0


def cmd_lidars(args) -> int:
    from sim.lidar import lidar_names, load_lidar
    for name in lidar_names():
        c = load_lidar(name)
        fov = c.field_of_view * 180.0 / 3.141592653589793
        print(f"{name:12s} {c.model:24s} {fov:6.1f} deg  {c.beams:5d} beams  {c.rate:5.1f} Hz  "
              f"{c.range_min:.2f}-{c.range_max:g} m")
    return 0


def cmd_show(args) -> int:
    from sim.logs import read_log
    from sim.plot import plot_log
    log = read_log(args.log)
    world = _log_world(log, args.log)
    out = args.out or str(Path(args.log).with_suffix(".png"))
    check_out_file(out)
    plot_log(log, world, out)
    print(out)
    return 0


def _is_bag(path: Path) -> bool:
    return path.suffix in (".bag", ".mcap", ".db3") or (path.is_dir() and (path / "metadata.yaml").exists())


def cmd_import(args) -> int:
    from sim.logs import import_log, write_log
    out = check_out_file(args.out)
    if out.exists() and not args.force:
        raise InputError(f"{out}: exists already (--force overwrites it)")
    if _is_bag(Path(args.file)):
        from sim.logs import import_bag
        log = import_bag(args.file, args.scan_topic, args.odom_topic, args.imu_topic)
    else:
        log = import_log(args.file, fmt=args.format)
    for warning in log.meta.get("import_warnings", []):
        print(f"warning: {args.file}: {warning}", file=sys.stderr)
    write_log(log, args.out)
    print(f"{args.out}: {log.n_scans} scans, {log.duration:.1f} s")
    return 0


def cmd_export(args) -> int:
    from sim.logs import export_bag, read_log
    from sim.logs.ros_export import DEFAULT_EPOCH
    out = Path(args.out)
    if out.exists():
        raise InputError(f"{out}: exists already (a bag is never overwritten)")
    log = read_log(args.log)
    export_bag(log, out, args.format, DEFAULT_EPOCH if args.epoch is None else args.epoch)
    maps = _write_true_map(log, out, args.log)
    print(f"{out}: {log.n_scans} scans, {log.duration:.1f} s" + (f"; true map {maps}" if maps else ""))
    return 0


def _write_true_map(log, out: Path, log_path: str) -> str:
    """The world's true map beside the bag (`<bag>_map.yaml` + .pgm), when the log's world is
    known; the YAML path written, or '' for a log without a world."""
    from worlds import rasterize, write_map
    world = _log_world(log, log_path)
    if world is None:
        return ""
    path = out.with_name(f"{out.stem}_map.yaml")
    write_map(rasterize(world), path)
    return str(path)


def main(argv: list[str] | None = None) -> int:
    commands = {"record": cmd_record, "show": cmd_show, "import": cmd_import, "export": cmd_export,
                "lidars": cmd_lidars}
    return run_cli(build_parser, lambda args: commands[args.command](args), argv)


if __name__ == "__main__":
    sys.exit(main())
