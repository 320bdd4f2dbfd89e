"""World -> ground-truth occupancy Grid: what a perfect lidar map of the world looks like.

The rule (one convention everywhere: a point (x, y) lies in cell
(floor((y - oy) / res), floor((x - ox) / res)), the convention of ray insertion):
  - occupied (1.0): a cell holding a point of a wall surface that faces the free space
    around the start (the boundary of World.free_space). A lidar beam ends on such a
    surface point, so these are exactly the cells a perfect lidar can hit, whatever the
    walls' angles. The surfaces are sampled every resolution / 16 m, so a cell the
    surface only clips at a corner by less than ~3 mm may be left out (a beam would
    almost never end there either).
  - free (0.0): any other cell whose centre lies in World.free_space and that is
    4-connected to the cell holding the start pose (flood fill);
  - unknown (NaN): everything else (wall interiors, the outside, unreachable rooms).
For surfaces that run along the grid axes and lie less than half a cell inside their
cell on the solid side -- the shipped worlds put every surface 0.015 m past a cell edge,
e.g. a wall 0.12 m thick centred on x = 1.025 has surfaces at 0.965 and 1.085 -- this is
the same as "cells whose centre is inside the solid and that border (8-neighbourhood)
a free cell", which the tests check.
The grid covers the solid's bounds plus a margin of `MARGIN_CELLS` cells; its origin is a
multiple of the resolution, so cell edges lie on multiples of the resolution.
"""
from __future__ import annotations

import math

import numpy as np
import shapely

from worlds.grid import Grid
from worlds.limits import check_grid_cells
from worlds.model import World
from worlds.yamlio import InputError

__all__ = ["rasterize", "true_walls", "grid_frame", "cell_centres", "surface_points", "MARGIN_CELLS"]

MARGIN_CELLS = 3


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
    check_grid_cells(rows, cols, f"{world.source or world.name}: resolution",
                     f"{res:g} m over {xmax - xmin:.3g} m x {ymax - ymin:.3g} m")
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
    from scipy import ndimage   # scipy's import is slow; only the flood fill needs it

    ox, oy, res, rows, cols = grid_frame(world, resolution)
    free_geom = world.free_space
    prob = np.full((rows, cols), np.nan)
    if free_geom.is_empty:
        return Grid(prob, res, np.array([ox, oy, 0.0]))
    surface = _surface_mask(free_geom, ox, oy, res, rows, cols)
    X, Y = cell_centres(ox, oy, res, rows, cols)
    shapely.prepare(free_geom)
    open_ = shapely.contains_xy(free_geom, X, Y) & ~surface
    r = int(math.floor((world.start[1] - oy) / res))
    c = int(math.floor((world.start[0] - ox) / res))
    labels, _ = ndimage.label(open_, structure=ndimage.generate_binary_structure(2, 1))
    if 0 <= r < rows and 0 <= c < cols and labels[r, c] > 0:
        prob[labels == labels[r, c]] = 0.0
    prob[surface] = 1.0
    return Grid(prob, res, np.array([ox, oy, 0.0]))


def true_walls(world: World, resolution: float | None = None) -> Grid:
    """The occupied cells of rasterize(world, resolution) alone: prob 1.0 there, NaN
    elsewhere (no free cells), on the same frame. For what needs only the walls (coverage),
    without the free-space test and flood fill."""
    ox, oy, res, rows, cols = grid_frame(world, resolution)
    prob = np.full((rows, cols), np.nan)
    free_geom = world.free_space
    if not free_geom.is_empty:
        prob[_surface_mask(free_geom, ox, oy, res, rows, cols)] = 1.0
    return Grid(prob, res, np.array([ox, oy, 0.0]))


def _surface_mask(free_geom, ox: float, oy: float, res: float, rows: int, cols: int) -> np.ndarray:
    """(rows, cols) bool: cells holding a point of the free space's boundary (sampled every
    res / 16 m): the occupied cells of the rule above."""
    surface = np.zeros((rows, cols), dtype=bool)
    pts = surface_points(free_geom, res / 16.0)
    sr = np.floor((pts[:, 1] - oy) / res).astype(np.int64)
    sc = np.floor((pts[:, 0] - ox) / res).astype(np.int64)
    surface[sr, sc] = True
    return surface


def surface_points(region, step: float) -> np.ndarray:
    """(N, 2) points every <= step m along the boundary rings of a shapely polygon (m)."""
    out = []
    for poly in getattr(region, "geoms", [region]):
        for ring in [poly.exterior, *poly.interiors]:
            xy = np.asarray(ring.coords)
            for a, b in zip(xy[:-1], xy[1:]):
                n = max(1, int(math.ceil(np.hypot(*(b - a)) / step)))
                out.append(a + (np.arange(n + 1)[:, None] / n) * (b - a))
    return np.vstack(out) if out else np.zeros((0, 2))
