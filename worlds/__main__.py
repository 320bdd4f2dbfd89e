"""Command line: python -m worlds list | show NAME|FILE [--out PNG] | render NAME|FILE --out DIR."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from worlds.yamlio import InputError


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m worlds", description="YAML worlds and their true maps.")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the shipped worlds: name, size, wall length, route given")
    s = sub.add_parser("show", help="PNG of a world's walls, start pose and route")
    s.add_argument("world", help="a shipped world name or a path to a world .yaml")
    s.add_argument("--out", help="PNG path (default: NAME.png in the current folder)")
    s.add_argument("--planned", action="store_true",
                   help="draw the planned covering route even if the world gives one")
    r = sub.add_parser("render", help="write the ground-truth map pair DIR/NAME.yaml + DIR/NAME.pgm")
    r.add_argument("world", help="a shipped world name or a path to a world .yaml")
    r.add_argument("--out", required=True, help="output folder")
    r.add_argument("--resolution", type=float, default=None, help="cell size in m (default: the world's)")
    r.add_argument("--png", action="store_true", help="also write DIR/NAME.png for people")
    return p


def cmd_list() -> list[str]:
    """One line per shipped world: name, interior size, wall length, route."""
    from worlds.load import list_worlds, load_world
    lines = [f"{'name':14s} {'size (m)':>13s} {'walls (m)':>9s}  route"]
    for name in list_worlds():
        w = load_world(name)
        minx, miny, maxx, maxy = w.free_space.bounds
        route = f"{len(w.route)} waypoints" if w.route is not None else "planned"
        lines.append(f"{name:14s} {maxx - minx:6.2f} x {maxy - miny:5.2f} {w.wall_length:9.2f}  {route}")
    return lines


def cmd_show(world_arg: str, out: str | None, planned: bool = False) -> Path:
    """Write a PNG of the world; returns its path."""
    from worlds.load import load_world
    from worlds.plot import save_world_png
    from worlds.route import plan_route, route_for
    w = load_world(world_arg)
    route = plan_route(w) if planned else route_for(w)
    path = Path(out) if out else Path(f"{w.name}.png")
    path.parent.mkdir(parents=True, exist_ok=True)
    save_world_png(w, path, route)
    return path


def cmd_render(world_arg: str, out: str, resolution: float | None = None, png: bool = False) -> Path:
    """Write DIR/NAME.yaml + DIR/NAME.pgm (the ground truth); returns the YAML path."""
    from worlds.load import load_world
    from worlds.mapio import write_map
    from worlds.raster import rasterize
    if resolution is not None and not resolution > 0:
        raise InputError(f"--resolution: must be positive, got {resolution}")
    w = load_world(world_arg)
    grid = rasterize(w, resolution)
    d = Path(out)
    if d.exists() and not d.is_dir():
        raise InputError(f"{d}: --out must be a folder")
    yp = d / f"{w.name}.yaml"
    write_map(grid, yp)
    if png:
        from worlds.plot import save_map_png
        save_map_png(grid, d / f"{w.name}.png", title=f"{w.name}: ground truth")
    return yp


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.command == "list":
            print("\n".join(cmd_list()))
        elif args.command == "show":
            print(cmd_show(args.world, args.out, args.planned))
        else:
            yp = cmd_render(args.world, args.out, args.resolution, args.png)
            print(f"{yp} + {yp.with_suffix('.pgm').name}")
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
