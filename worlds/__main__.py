"""Command line: python -m worlds list [PATH ...] | show NAME|FILE [--out PNG] |
render NAME|FILE --out DIR [--image-format pgm|png] |
generate KIND --seed S [--size WxH] --out FILE.yaml."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from worlds.cli import Parser, check_out_dir, check_out_file, non_negative_int, positive_float, run_cli
from worlds.paths import path_inside
from worlds.yamlio import InputError


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="python -m worlds", description="YAML worlds and their true maps.")
    sub = p.add_subparsers(dest="command", required=True)
    ls = sub.add_parser("list", help="worlds: name (or file), size, wall length, route given")
    ls.add_argument("paths", nargs="*", metavar="PATH",
                    help="world .yaml files or folders (every *.yaml in them); default: the shipped worlds")
    s = sub.add_parser("show", help="PNG of a world's walls, start pose and route")
    s.add_argument("world", help="a shipped world name or a path to a world .yaml")
    s.add_argument("--out", help="PNG path (default: NAME.png in the current folder)")
    s.add_argument("--planned", action="store_true",
                   help="draw the planned covering route even if the world gives one")
    r = sub.add_parser("render", help="write the ground-truth map pair DIR/NAME.yaml + DIR/NAME.pgm "
                                      "(or .png)")
    r.add_argument("world", help="a shipped world name or a path to a world .yaml")
    r.add_argument("--out", required=True, help="output folder")
    r.add_argument("--resolution", type=positive_float, default=None,
                   help="cell size in m, > 0 (default: the world's)")
    r.add_argument("--image-format", choices=["pgm", "png"], default="pgm",
                   help="the map image: DIR/NAME.pgm (default) or DIR/NAME.png (8-bit grey, "
                        "as Nav2 reads)")
    r.add_argument("--png", action="store_true", help="also write DIR/NAME.png for people")
    g = sub.add_parser("generate", help="write a procedurally drawn world (same arguments, same file)")
    g.add_argument("kind", help="office | warehouse | hall | loop")
    g.add_argument("--seed", type=non_negative_int, required=True, help="non-negative integer")
    g.add_argument("--size", help="WxH in metres, e.g. 10x8 (default per kind: office 10x8, "
                                  "warehouse 12x9, hall 9x7, loop 12x8)")
    g.add_argument("--out", required=True, help="the world .yaml to write (folders are created)")
    return p


def cmd_list(paths: list[str] = ()) -> list[str]:
    """One line per world: name (the file for PATH arguments), interior size, wall length, route.

    paths: world .yaml files or folders (every *.yaml in them); none: the shipped worlds.
    """
    from worlds.load import list_worlds, load_world
    labels = [str(p) for p in _yaml_files(paths)] if paths else list_worlds()
    width = max([14] + [len(label) for label in labels])
    lines = [f"{'file' if paths else 'name':{width}s} {'size (m)':>13s} {'walls (m)':>9s}  route"]
    for label in labels:
        w = load_world(label)
        minx, miny, maxx, maxy = w.free_space.bounds
        route = f"{len(w.route)} waypoints" if w.route is not None else "planned"
        size = f"{maxx - minx:6.2f} x {maxy - miny:5.2f}"
        lines.append(f"{label:{width}s} {size} {w.wall_length:9.2f}  {route}")
    return lines


def _yaml_files(paths: list[str]) -> list[Path]:
    """The files among `paths` and every *.yaml in the folders among them, in order given."""
    out = []
    for arg in paths:
        p = Path(arg)
        if p.is_dir():
            found = sorted(p.glob("*.yaml"))
            if not found:
                raise InputError(f"{p}: no .yaml files in this folder")
            out += found
        elif p.is_file():
            out.append(p)
        else:
            raise InputError(f"{p}: no such file or folder")
    return out


def cmd_show(world_arg: str, out: str | None, planned: bool = False) -> Path:
    """Write a PNG of the world; returns its path."""
    from worlds.load import load_world
    from worlds.plot import save_world_png
    from worlds.route import plan_route, route_for
    w = load_world(world_arg)
    path = check_out_file(out if out else f"{w.name}.png")
    route = plan_route(w) if planned else route_for(w)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_world_png(w, path, route)
    return path


def cmd_render(world_arg: str, out: str, resolution: float | None = None, png: bool = False,
               image_format: str = "pgm") -> tuple[Path, Path]:
    """Write DIR/NAME.yaml + DIR/NAME.pgm or .png (the ground truth), and with `png` a picture
    DIR/NAME.png; returns the YAML and map image paths."""
    from worlds.load import load_world
    from worlds.mapio import write_map
    from worlds.raster import rasterize
    if png and image_format == "png":
        raise InputError("--png draws DIR/NAME.png, the map image of --image-format png; "
                         "give one of them")
    d = check_out_dir(out)
    w = load_world(world_arg)
    grid = rasterize(w, resolution)
    yp = path_inside(d, f"{w.name}.yaml", what=f"{world_arg}: name")
    image = write_map(grid, yp, image_format)
    if png:
        from worlds.plot import save_map_png
        save_map_png(grid, path_inside(d, f"{w.name}.png", what=f"{world_arg}: name"),
                     title=f"{w.name}: ground truth")
    return yp, image


def cmd_generate(kind: str, seed: int, size: str | None, out: str) -> tuple[Path, str]:
    """Write the generated world to `out` (atomically); returns its path and a one-line summary."""
    import numpy as np

    from worlds.generate import generate_yaml, parse_size
    from worlds.load import load_world
    from worlds.yamlio import atomic_write_text
    path = Path(out)
    if path.suffix.lower() not in (".yaml", ".yml"):
        raise InputError(f"--out: expected a .yaml file, got {out!r}")
    check_out_file(path)
    text = generate_yaml(kind, seed, parse_size(size) if size is not None else None)
    atomic_write_text(path, text)
    w = load_world(path)
    minx, miny, maxx, maxy = w.free_space.bounds
    length = float(np.hypot(*np.diff(np.vstack([w.start[:2], w.route]), axis=0).T).sum())
    return path, (f"{w.name}: {maxx - minx:.2f} x {maxy - miny:.2f} m inside, {len(w.walls)} walls "
                  f"({w.wall_length:.1f} m), {len(w.obstacles)} obstacles, route {length:.1f} m "
                  f"({len(w.route)} waypoints)")


def _dispatch(args) -> None:
    if args.command == "list":
        print("\n".join(cmd_list(args.paths)))
    elif args.command == "generate":
        path, summary = cmd_generate(args.kind, args.seed, args.size, args.out)
        print(f"{path}: {summary}")
    elif args.command == "show":
        print(cmd_show(args.world, args.out, args.planned))
    else:
        yp, image = cmd_render(args.world, args.out, args.resolution, args.png, args.image_format)
        print(f"{yp} + {image.name}")


def main(argv: list[str] | None = None) -> int:
    return run_cli(build_parser, _dispatch, argv)


if __name__ == "__main__":
    sys.exit(main())
