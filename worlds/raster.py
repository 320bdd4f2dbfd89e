"""World -> ground-truth occupancy Grid: what a perfect lidar map of the world looks like.

The rule (one convention everywhere: a point (x, y) lies in cell
(floor((y - oy) / res), floor((x - ox) / res)), the convention of ray insertion):
  - solid cell: its centre lies inside the solid (the union of walls and obstacles);
  - free (0.0): a non-solid cell whose centre lies in World.free_space, 4-connected to the
    cell holding the start pose (flood fill) -- the space the robot can see into;
  - occupied (1.0): a solid cell with a free cell among its 8 neighbours -- the wall
    surface a lidar can see; a beam ending on a wall surface lands in the cell holding
    that surface point, and with surfaces kept away from cell edges that cell's centre is
    inside the solid, so the cells a perfect lidar hits are exactly these cells (the
    diagonal neighbour matters at inside corners, whose corner cell beams reach);
  - unknown (NaN): everything else (wall interiors, the outside, unreachable rooms).
The grid covers the solid's bounds plus a margin of `MARGIN_CELLS` cells; its origin is a
multiple of the resolution, so cell edges lie on multiples of the resolution (the shipped
worlds put wall surfaces 0.015 m from those edges, on the solid side of cell centres).
"""
from __future__ import annotations

import math

import numpy as np
import shapely
from scipy import ndimage

from worlds.grid import Grid
from worlds.model import World
from worlds.yamlio import InputError

__all__ = ["rasterize", "grid_frame", "cell_centres", "MARGIN_CELLS"]

MARGIN_CELLS = 3
_FOUR = ndimage.generate_binary_structure(2, 1)
_EIGHT = ndimage.generate_binary_structure(2, 2)


def _snap(v: float) -> float:
    # k * res in floating point gives 0.30000000000000004; keep origins as written by hand
    return float(round(v, 9))


def grid_frame(world: World, resolution: float | None = None) -> tuple[float, float, float, int, int]:
    """(ox, oy, resolution, rows, cols) of the ground-truth grid of `world`."""
    res = float(resolution if resolution is not None else world.resolution)
    if not res > 0:
        raise InputError(f"{world.source or world.name}: resolution: must be positive, got {res}")
    if world.solid.is_empty:
        raise InputError(f"{world.source or world.name}: walls: the world has no walls")
    xmin, ymin, xmax, ymax = world.bounds
    c0 = math.floor(xmin / res) - MARGIN_CELLS
    r0 = math.floor(ymin / res) - MARGIN_CELLS
    cols = math.ceil(xmax / res) + MARGIN_CELLS - c0
    rows = math.ceil(ymax / res) + MARGIN_CELLS - r0
    return _snap(c0 * res), _snap(r0 * res), res, rows, cols


def cell_centres(ox: float, oy: float, res: float, rows: int, cols: int) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) arrays of world x and y (m) of the cell centres."""
    x = ox + (np.arange(cols) + 0.5) * res
    y = oy + (np.arange(rows) + 0.5) * res
    return np.meshgrid(x, y)


def rasterize(world: World, resolution: float | None = None) -> Grid:
    """The ground-truth Grid of `world` (rule in the module docstring).

    resolution: m per cell, default world.resolution. Returns prob 1.0 occupied,
    0.0 free, NaN unknown; origin yaw 0.
    """
    ox, oy, res, rows, cols = grid_frame(world, resolution)
    X, Y = cell_centres(ox, oy, res, rows, cols)
    solid_geom = world.solid
    shapely.prepare(solid_geom)
    solid = shapely.contains_xy(solid_geom, X, Y)
    free_geom = world.free_space
    shapely.prepare(free_geom)
    open_ = shapely.contains_xy(free_geom, X, Y) & ~solid
    r = int(math.floor((world.start[1] - oy) / res))
    c = int(math.floor((world.start[0] - ox) / res))
    labels, _ = ndimage.label(open_, structure=_FOUR)
    prob = np.full((rows, cols), np.nan)
    if 0 <= r < rows and 0 <= c < cols and labels[r, c] > 0:
        free = labels == labels[r, c]
        occupied = solid & ndimage.binary_dilation(free, structure=_EIGHT)
        prob[free] = 0.0
        prob[occupied] = 1.0
    return Grid(prob, res, np.array([ox, oy, 0.0]))
