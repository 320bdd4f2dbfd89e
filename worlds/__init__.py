"""Worlds as YAML, ground-truth occupancy grids and ROS map files."""
from worlds.grid import FREE_THRESH, OCCUPIED_THRESH, Grid
from worlds.load import list_worlds, load_world
from worlds.mapio import read_map, write_map
from worlds.coverage import wall_coverage
from worlds.plot import save_map_png, save_world_png
from worlds.raster import rasterize
from worlds.route import plan_route, route_for
from worlds.generate import KINDS, generate_world, generate_yaml
from worlds.model import ROBOT_RADIUS, Obstacle, Wall, World
from worlds.yamlio import InputError, from_dict, load_yaml

__all__ = ["Grid", "World", "Wall", "Obstacle", "ROBOT_RADIUS", "InputError", "from_dict",
           "load_yaml", "OCCUPIED_THRESH", "FREE_THRESH", "load_world", "list_worlds", "read_map",
           "write_map", "rasterize", "plan_route", "route_for", "wall_coverage",
           "save_map_png", "save_world_png", "KINDS", "generate_world", "generate_yaml"]
