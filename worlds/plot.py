"""Pictures for people: a world (walls, start, route) and an occupancy grid, as PNG.

matplotlib is imported here only (STYLE.md: drawing is a separate call on plain data).
"""
from __future__ import annotations

import os

import numpy as np

from worlds.grid import Grid
from worlds.model import World

__all__ = ["plot_grid", "plot_world", "save_map_png", "save_world_png"]


def _figure(width_m: float, height_m: float):
    import matplotlib
    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure
    aspect = height_m / max(width_m, 1e-9)
    w = 7.0
    return Figure(figsize=(w, min(max(w * aspect, 2.5), 14.0)))


def plot_grid(ax, grid: Grid) -> None:
    """Draw `grid` on `ax`: occupied black, free white, unknown grey, axes in metres."""
    img = np.full(grid.shape, 0.75)
    img[grid.free()] = 1.0
    img[grid.occupied()] = 0.0
    mid = grid.known() & ~grid.free() & ~grid.occupied()
    img[mid] = 1.0 - grid.prob[mid]
    ax.imshow(img, origin="lower", extent=grid.extent(), cmap="gray", vmin=0.0, vmax=1.0,
              interpolation="nearest")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def plot_world(ax, world: World, route: np.ndarray | None = None) -> None:
    """Draw the walls and obstacles, the start pose (arrow) and the route ((K, 2) m) if any."""
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath

    from shapely.geometry.polygon import orient

    polys = getattr(world.solid, "geoms", [world.solid])
    for poly in polys:
        if poly.is_empty:
            continue
        poly = orient(poly, 1.0)  # holes wound against the outline: the nonzero rule leaves them empty
        rings = [poly.exterior, *poly.interiors]
        verts = np.vstack([np.asarray(r.coords) for r in rings])
        codes = np.concatenate([[MplPath.MOVETO] + [MplPath.LINETO] * (len(r.coords) - 2)
                                + [MplPath.CLOSEPOLY] for r in rings])
        ax.add_patch(PathPatch(MplPath(verts, codes), facecolor="0.15", edgecolor="none"))
    if route is not None and len(route):
        path = np.vstack([world.start[:2], route])
        ax.plot(path[:, 0], path[:, 1], "-", color="tab:red", lw=1.0, label="route")
        ax.plot(route[:, 0], route[:, 1], ".", color="tab:red", ms=3)
    x, y, yaw = world.start
    ax.plot([x], [y], "o", color="tab:blue", ms=6, label="start")
    ax.arrow(x, y, 0.3 * np.cos(yaw), 0.3 * np.sin(yaw), width=0.02, color="tab:blue")
    xmin, ymin, xmax, ymax = world.bounds
    pad = 0.2
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def save_world_png(world: World, path: str | os.PathLike, route: np.ndarray | None = None) -> None:
    """PNG of `world` with its start and `route` ((K, 2) m; default world.route)."""
    if route is None:
        route = world.route
    xmin, ymin, xmax, ymax = world.bounds
    fig = _figure(xmax - xmin, ymax - ymin)
    ax = fig.add_subplot(111)
    plot_world(ax, world, route)
    ax.set_title(f"{world.name}" + (f": {world.description}" if len(world.description) < 50 else ""))
    fig.tight_layout()
    fig.savefig(os.fspath(path), dpi=110)


def save_map_png(grid: Grid, path: str | os.PathLike, title: str = "") -> None:
    """PNG of an occupancy grid (occupied black, free white, unknown grey)."""
    fig = _figure(grid.width_m, grid.height_m)
    ax = fig.add_subplot(111)
    plot_grid(ax, grid)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(os.fspath(path), dpi=110)
