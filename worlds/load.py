"""World YAML -> World, with errors that name the file, the field and the problem.

Schema (docs/worlds.md): name, description, resolution, walls {thickness, polylines},
obstacles [{polygon} | {circle: {center, radius, sides}} | {box: {center, size, yaw}}],
robot {start: [x, y, yaw]}, route [[x, y], ...].  Besides the types, a world is checked
for: a free region enclosed by walls around the start; a start pose at least the robot
radius (0.105 m) from every wall; route waypoints that the robot's centre can reach from
the start (inside the free region shrunk by the robot radius, in the start's component).
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Point

from worlds.limits import MAX_COORDINATE, check_coordinates
from worlds.model import ROBOT_RADIUS, Wall, World, make_obstacle
from worlds.paths import check_name, names_a_file
from worlds.yamlio import InputError, check_keys, load_yaml, short

__all__ = ["load_world", "list_worlds", "world_from_dict", "world_dir", "reachable_region",
           "MAX_OBSTACLES", "MAX_WALL_POINTS", "MAX_CIRCLE_SIDES"]

# Caps on a world's size, so that a small file cannot take gigabytes (docs/formats.md,
# "Limits"); the largest generated world holds a few hundred of each
MAX_OBSTACLES = 2_000
MAX_WALL_POINTS = 20_000
MAX_CIRCLE_SIDES = 360

_TOP_KEYS = ["name", "description", "resolution", "walls", "obstacles", "robot", "route"]
_DEFAULT_THICKNESS = 0.10


def world_dir() -> Path:
    """The folder holding the shipped world YAML files (the worlds package itself)."""
    return Path(__file__).resolve().parent


def list_worlds() -> list[str]:
    """Names of the shipped worlds, sorted."""
    return sorted(p.stem for p in world_dir().glob("*.yaml"))


def load_world(name_or_path: str | os.PathLike) -> World:
    """Load a world by shipped name (e.g. 'swirl_l') or from a YAML path.

    Raises InputError('<file>: <field>: <problem>') for any bad input.
    """
    s = str(name_or_path)
    p = Path(s)
    if names_a_file(s):
        where = s
    else:
        p = world_dir() / f"{s}.yaml"
        if not p.is_file():
            raise InputError(f"{s}: no such world (shipped worlds: {', '.join(list_worlds())}; "
                             "or give a path to a .yaml file)")
        where = p.name
    data = load_yaml(p)
    return world_from_dict(data, where=where, default_name=p.stem)


# --- field checks ------------------------------------------------------------------------

def _num(v: Any, where: str, field: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{where}: {field}: expected a number, got {short(v)}")
    if abs(v) > MAX_COORDINATE:
        # lengths and positions alike: shapely and the grids overflow long before 1e308
        raise InputError(f"{where}: {field}: {short(v)} is beyond {MAX_COORDINATE:g} m")
    return float(v)


def _pos(v: Any, where: str, field: str) -> float:
    x = _num(v, where, field)
    if x <= 0:
        raise InputError(f"{where}: {field}: must be positive, got {short(v)}")
    return x


def _point(v: Any, where: str, field: str) -> list[float]:
    if (not isinstance(v, (list, tuple)) or len(v) != 2
            or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c)
                   for c in v)):
        raise InputError(f"{where}: {field}: expected a point [x, y], got {short(v)}")
    check_coordinates(v, where, field)
    return [float(v[0]), float(v[1])]


def _points(v: Any, where: str, field: str, minimum: int) -> np.ndarray:
    if not isinstance(v, (list, tuple)):
        raise InputError(f"{where}: {field}: expected a list of points [[x, y], ...], got {short(v)}")
    pts = [_point(p, where, f"{field}[{i}]") for i, p in enumerate(v)]
    if len(pts) < minimum:
        raise InputError(f"{where}: {field}: expected at least {minimum} point{'s' if minimum > 1 else ''}, "
                         f"got {len(pts)}")
    return np.asarray(pts, dtype=np.float64)


def _mapping(v: Any, where: str, field: str, allowed: list[str], required: list[str] = ()) -> dict:
    if not isinstance(v, dict):
        raise InputError(f"{where}: {field}: expected a mapping with keys {', '.join(allowed)}, "
                         f"got {short(v)}")
    check_keys(v, allowed, where, field)
    for key in required:
        if key not in v:
            raise InputError(f"{where}: {field}.{key}: missing required field")
    return v


def _walls(v: Any, where: str) -> tuple[Wall, ...]:
    v = _mapping(v, where, "walls", ["thickness", "polylines"], ["polylines"])
    thick = _pos(v.get("thickness", _DEFAULT_THICKNESS), where, "walls.thickness")
    lines = v["polylines"]
    if not isinstance(lines, (list, tuple)):
        raise InputError(f"{where}: walls.polylines: expected a list of polylines, got {short(lines)}")
    count = sum(len(line) if isinstance(line, (list, tuple)) else
                len(line.get("points") or ()) if isinstance(line, dict) else 1 for line in lines)
    if count > MAX_WALL_POINTS:
        raise InputError(f"{where}: walls.polylines: {count:,} points, more than the limit of "
                         f"{MAX_WALL_POINTS:,}")
    walls = []
    for i, line in enumerate(lines):
        field = f"walls.polylines[{i}]"
        t = thick
        if isinstance(line, dict):
            line = _mapping(line, where, field, ["points", "thickness"], ["points"])
            if "thickness" in line:
                t = _pos(line["thickness"], where, f"{field}.thickness")
            pts = _points(line["points"], where, f"{field}.points", 2)
        else:
            pts = _points(line, where, field, 2)
        if np.all(np.linalg.norm(np.diff(pts, axis=0), axis=1) == 0):
            raise InputError(f"{where}: {field}: all points coincide (a wall needs length)")
        walls.append(Wall(pts, t))
    return tuple(walls)


def _obstacles(v: Any, where: str) -> tuple:
    if not isinstance(v, (list, tuple)):
        raise InputError(f"{where}: obstacles: expected a list, got {short(v)}")
    if len(v) > MAX_OBSTACLES:
        raise InputError(f"{where}: obstacles: {len(v):,} obstacles, more than the limit of "
                         f"{MAX_OBSTACLES:,}")
    kinds = ["polygon", "circle", "box"]
    out = []
    for i, item in enumerate(v):
        field = f"obstacles[{i}]"
        item = _mapping(item, where, field, kinds)
        if len(item) != 1:
            raise InputError(f"{where}: {field}: expected exactly one of {', '.join(kinds)}, "
                             f"got {', '.join(map(str, item)) or 'nothing'}")
        kind, val = next(iter(item.items()))
        f = f"{field}.{kind}"
        if kind == "polygon":
            params = {"points": _points(val, where, f, 3).tolist()}
        elif kind == "circle":
            val = _mapping(val, where, f, ["center", "radius", "sides"], ["center", "radius"])
            params = {"center": _point(val["center"], where, f"{f}.center"),
                      "radius": _pos(val["radius"], where, f"{f}.radius")}
            if "sides" in val:
                sides = val["sides"]
                if (isinstance(sides, bool) or not isinstance(sides, int)
                        or not 8 <= sides <= MAX_CIRCLE_SIDES):
                    raise InputError(f"{where}: {f}.sides: expected an integer from 8 to "
                                     f"{MAX_CIRCLE_SIDES}, got {short(sides)}")
                params["sides"] = sides
        else:
            val = _mapping(val, where, f, ["center", "size", "yaw"], ["center", "size"])
            size = _point(val["size"], where, f"{f}.size")
            if min(size) <= 0:
                raise InputError(f"{where}: {f}.size: must be positive, got {short(val['size'])}")
            params = {"center": _point(val["center"], where, f"{f}.center"), "size": size,
                      "yaw": _num(val.get("yaw", 0.0), where, f"{f}.yaw")}
        obst = make_obstacle(kind, params)
        if not obst.polygon.is_valid or obst.polygon.area <= 0:
            raise InputError(f"{where}: {f}: not a simple polygon with area "
                             f"({shapely.is_valid_reason(obst.polygon)})")
        out.append(obst)
    return tuple(out)


def _start(v: Any, where: str) -> np.ndarray:
    v = _mapping(v, where, "robot", ["start"], ["start"])
    s = v["start"]
    if (not isinstance(s, (list, tuple)) or len(s) != 3
            or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c)
                   for c in s)):
        raise InputError(f"{where}: robot.start: expected a pose [x, y, yaw], got {short(s)}")
    check_coordinates(s[:2], where, "robot.start")
    yaw = math.atan2(math.sin(s[2]), math.cos(s[2]))
    if yaw == -math.pi:
        yaw = math.pi
    return np.array([float(s[0]), float(s[1]), yaw])


# --- the world as a whole ----------------------------------------------------------------

def reachable_region(world: World, clearance: float = ROBOT_RADIUS):
    """Where the robot's centre can go from the start: World.free_space shrunk by
    `clearance` (m), the connected part that holds the start (shapely polygon, maybe empty)."""
    region = world.free_space.buffer(-clearance, quad_segs=16)
    start = Point(world.start[0], world.start[1])
    for part in getattr(region, "geoms", [region]):
        if part.covers(start):
            return part
    return shapely.Polygon()


def world_from_dict(data: Any, where: str = "<world>", default_name: str = "world") -> World:
    """Build and check a World from parsed YAML; errors name `where` and the field."""
    if not isinstance(data, dict):
        raise InputError(f"{where}: top level: expected a mapping with keys "
                         f"{', '.join(_TOP_KEYS)}, got {short(data)}")
    check_keys(data, _TOP_KEYS, where)
    for key in ("walls", "robot"):
        if key not in data:
            raise InputError(f"{where}: {key}: missing required field")
    if "name" in data:
        name = check_name(data["name"], where, "name")
    else:
        name = check_name(default_name, where, "name (missing; the file's name stands in)")
    desc = data.get("description", "")
    if desc is None:
        desc = ""
    if not isinstance(desc, str):
        raise InputError(f"{where}: description: expected a string, got {short(desc)}")
    res = _pos(data.get("resolution", 0.05), where, "resolution")
    walls = _walls(data["walls"], where)
    obstacles = _obstacles(data.get("obstacles") or [], where)
    start = _start(data["robot"], where)
    route = None
    if data.get("route") is not None:
        route = _points(data["route"], where, "route", 1)
    world = World(name=name, walls=walls, obstacles=obstacles, start=start, route=route,
                  description=desc, resolution=res, source=where)
    _check_geometry(world, where)
    return world


def _check_geometry(world: World, where: str) -> None:
    start = Point(world.start[0], world.start[1])
    if world.solid.covers(start):
        raise InputError(f"{where}: robot.start: inside a wall at ({world.start[0]:g}, "
                         f"{world.start[1]:g})")
    if world.free_space.is_empty:
        raise InputError(f"{where}: walls: no enclosed free space around the start "
                         f"({world.start[0]:g}, {world.start[1]:g}); the walls must close a room")
    gap = world.solid.distance(start)
    if gap < ROBOT_RADIUS:
        raise InputError(f"{where}: robot.start: {gap:.3f} m from a wall, within {ROBOT_RADIUS} m "
                         "(the robot radius) of a wall")
    if world.route is None:
        return
    region = reachable_region(world)
    for i, (x, y) in enumerate(world.route):
        p = Point(x, y)
        if world.solid.covers(p):
            raise InputError(f"{where}: route[{i}]: ({x:g}, {y:g}) is inside a wall")
        if not region.covers(p):
            d = world.solid.distance(p)
            if not world.free_space.covers(p):
                why = "outside the start's room"
            elif d < ROBOT_RADIUS:
                why = f"within {ROBOT_RADIUS} m (the robot radius) of a wall ({d:.3f} m)"
            else:
                why = "cut off by a passage narrower than the robot"
            raise InputError(f"{where}: route[{i}]: ({x:g}, {y:g}) not reachable from the start: {why}")
