"""Command line: python -m metrics score | trajectory | relations ...

  score      --map MAP.yaml --truth WORLD.yaml|TRUTH.yaml [--tau M] [--align MODE]
             [--start X,Y,YAW|none] [--tolerance N] [--picture OUT.png] [--title TEXT] [--json]
  trajectory --est EST.tum --truth GT.tum|LOG.npz [--segment M] [--json]
  relations  --traj EST.tum --relations FILE [--odom LOG] [--lookup interpolate|exact] [--json]
             (options and output are metrics.relations')

User errors (missing or malformed files, an empty map) print one line `error: ...` and exit 2.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from worlds.cli import Parser, check_out_file, integer, number, positive_float, run_cli, share_0_1
from worlds.jsonio import dumps
from worlds.yamlio import InputError

__all__ = ["main", "build_parser"]

# --tolerance k dilates both maps by a (2k+1)^2 square: cost grows as k^2, and 50 cells
# (2.5 m at 0.05 m) is already far past any tolerance that says something about a map
MAX_TOLERANCE = 50


def _pose_arg(text: str):
    if text.strip().lower() == "none":
        return None
    parts = text.split(",")
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y,YAW (numbers) or 'none', got {text!r}") from None
    if not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(f"expected X,Y,YAW (finite numbers) or 'none', got {text!r}")
    if len(vals) != 3:
        raise argparse.ArgumentTypeError(f"expected X,Y,YAW (3 numbers) or 'none', got {text!r}")
    return tuple(vals)


def _picture_arg(text: str) -> str:
    from metrics.plot import PICTURE_FORMATS

    if Path(text).suffix.lower().lstrip(".") not in PICTURE_FORMATS:
        names = [f".{f}" for f in PICTURE_FORMATS]
        raise argparse.ArgumentTypeError(
            f"expected a {', '.join(names[:-1])} or {names[-1]} file, got {text!r}")
    return text


def build_parser() -> argparse.ArgumentParser:
    from metrics.align import MODES
    from metrics.surface import DEFAULT_TAU_M

    p = Parser(prog="python -m metrics", description="Score maps and trajectories.")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("score", help="grid portion (precision, sensitivity), ADNN, SSIM of a map")
    s.add_argument("--map", required=True, help="estimated map (ROS map_server YAML + PGM)")
    s.add_argument("--truth", required=True,
                   help="the world's YAML (surface form and the study's cell rule) or a true map "
                        "(ROS map_server YAML + PGM: the cell rule only)")
    s.add_argument("--tau", type=number(0.0, 1.0), default=None, metavar="M",
                   help=f"tolerance of the surface form in metres, 0..1 (default "
                        f"{DEFAULT_TAU_M:g}); needs a world")
    s.add_argument("--align", default="auto", choices=MODES,
                   help="alignment mode (default auto: icp from --start, global if --start none)")
    s.add_argument("--start", type=_pose_arg, default=(0.0, 0.0, 0.0), metavar="X,Y,YAW",
                   help="prior transform map -> truth, i.e. the map frame's pose in the truth "
                        "frame (default 0,0,0: the map is in the world frame); 'none' = unknown")
    s.add_argument("--tolerance", type=integer(0, MAX_TOLERANCE), default=0,
                   help=f"match tolerance in cells, 0..{MAX_TOLERANCE} (default 0)")
    s.add_argument("--occupied-thresh", type=share_0_1, default=0.65,
                   help="a cell is occupied at p >= this (default 0.65)")
    s.add_argument("--picture", type=_picture_arg,
                   help="write the TP/FP/FN overlay here (.png, .pdf or .svg)")
    s.add_argument("--title", default="", help="title of the picture")
    s.add_argument("--json", action="store_true", help="print one JSON object")

    t = sub.add_parser("trajectory", help="ATE and RPE of a TUM trajectory against the true one")
    t.add_argument("--est", required=True, help="estimated trajectory (TUM)")
    t.add_argument("--truth", required=True, help="true trajectory: TUM file, or the sensor log (.npz) whose gt_pose to use")
    t.add_argument("--segment", type=positive_float, default=1.0,
                   help="RPE segment length, m (default 1)")
    t.add_argument("--json", action="store_true")

    r = sub.add_parser("relations", help="relations metric (Kuemmerle et al. 2009)")
    try:  # the relations module owns its options (--odom, --lookup, ...)
        from metrics.relations import add_relations_arguments
    except ImportError:
        r.add_argument("--traj", required=True, help="estimated trajectory (TUM)")
        r.add_argument("--relations", required=True, help="relations file")
        r.add_argument("--json", action="store_true")
    else:
        add_relations_arguments(r)
    return p


def _read_map(path: str):
    from worlds.mapio import read_map

    try:
        return read_map(path)
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a map description (binary file; expected the map's .yaml)") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, expected a map .yaml") from None


def _print(result: dict, as_json: bool, keys: list[str] | None = None) -> None:
    if as_json:
        print(dumps(result))
        return
    for k in keys or list(result):
        if k not in result:
            continue
        v = result[k]
        if isinstance(v, float):
            print(f"{k:24s} {v:.6g}")
        elif isinstance(v, dict):
            print(f"{k:24s} " + ", ".join(f"{a}={b:.6g}" if isinstance(b, float) else f"{a}={b}"
                                           for a, b in v.items()))
        else:
            print(f"{k:24s} {v}")


def _truth(path: str):
    """(true Grid, World or None) of --truth: a world YAML (it has `walls`) or a map pair."""
    from worlds.yamlio import load_yaml

    try:
        data = load_yaml(path)
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a YAML file (binary; expected the map's or the world's .yaml)") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, expected a map or world .yaml") from None
    if isinstance(data, dict) and "walls" in data:
        from worlds.load import load_world
        from worlds.raster import rasterize
        world = load_world(path)
        return rasterize(world), world
    return _read_map(path), None


def _score(args) -> int:
    from metrics.score import pose_of, save_overlay_png, score_map
    from metrics.surface import DEFAULT_TAU_M, classify_surface, visible_surfaces

    if args.picture:
        check_out_file(args.picture, "--picture")
    est = _read_map(args.map)
    truth, world = _truth(args.truth)
    if args.tau is not None and world is None:
        raise InputError(f"--tau: the surface form needs the world's YAML as --truth, "
                         f"{args.truth} is a raster map")
    tau = DEFAULT_TAU_M if args.tau is None else args.tau
    if not est.occupied(args.occupied_thresh).any():
        raise InputError(f"{args.map}: the map has no occupied cell (p >= {args.occupied_thresh}): "
                         "precision and ADNN undefined")
    surfaces = visible_surfaces(world) if world is not None else None
    # the benchmark's scorer (bench.task._score): the cell form under the alignment, the
    # surface form under it refined onto the surfaces
    res = score_map(est, truth, align=args.align, initial=args.start, tolerance=args.tolerance,
                    occupied_thresh=args.occupied_thresh, surfaces=surfaces, tau_m=tau)
    forms = {"precision": f"cell: the study's exact rule, tolerance {args.tolerance} cells"}
    if world is not None:
        forms["surface_precision"] = f"surface: wall surfaces of {world.name}, tau {tau:g} m"
    res["forms"] = forms
    if args.picture:
        if surfaces is not None:
            from metrics.plot import save_surface
            surface = classify_surface(est, surfaces, pose_of(res["surface_align"]), tau,
                                       args.occupied_thresh)
            save_surface(surface, args.picture, title=args.title)
        else:
            save_overlay_png(est, truth, res["align"], args.picture, title=args.title,
                             tolerance=args.tolerance, occupied_thresh=args.occupied_thresh)
    _print(res, args.json)
    return 0


def _trajectory(args) -> int:
    from metrics import registry
    from metrics.trajectory import TrajectoryContext
    from sim.logs.tum import read_tum

    et, ep = read_tum(args.est)
    if str(args.truth).endswith(".npz"):
        # a simulated sensor log carries the true path: no separate file needed
        from sim.logs import read_log
        log = read_log(args.truth)
        if not log.has_ground_truth:
            raise InputError(f"{args.truth}: the log has no ground truth (gt_t, gt_pose empty)")
        gt, gp = log.gt_t, log.gt_pose
    else:
        gt, gp = read_tum(args.truth)
    _print(registry.compute("trajectory", TrajectoryContext(et, ep, gt, gp, args.segment)),
           args.json)
    return 0


def _relations(args) -> int:
    try:
        from metrics.relations import relations_main
    except ImportError as err:
        raise InputError(f"relations metric not available: {err}") from None
    return relations_main(args)


def main(argv: list[str] | None = None) -> int:
    commands = {"score": _score, "trajectory": _trajectory, "relations": _relations}
    return run_cli(build_parser, lambda args: commands[args.command](args), argv)


if __name__ == "__main__":
    sys.exit(main())
