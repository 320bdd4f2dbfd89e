"""World, Wall, Obstacle: frozen dataclasses over shapely geometry.

A wall is a polyline thickened to `thickness` (flat-mitred joints, square caps, so a
closed chain has clean corners); an obstacle is a solid polygon, circle or box. The
union of all of them is `World.solid`: what the robot collides with and the lidar sees.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import shapely
from shapely.geometry import LineString, MultiPolygon, Point, Polygon
from shapely.geometry.base import BaseGeometry

__all__ = ["Wall", "Obstacle", "World", "ROBOT_RADIUS"]

# TurtleBot3 Burger footprint radius (m): start poses and waypoints keep this clearance.
ROBOT_RADIUS = 0.105
# circles are polygonised with this many segments per quarter: ~0.3 mm error at r = 0.2 m
_CIRCLE_QUAD_SEGS = 32


@dataclass(frozen=True, eq=False)
class Wall:
    """A chain of wall segments. points: (N, 2) m, N >= 2; thickness: m."""

    points: np.ndarray
    thickness: float

    @cached_property
    def polygon(self) -> BaseGeometry:
        line = LineString(self.points)
        return line.buffer(self.thickness / 2.0, cap_style="square", join_style="mitre", mitre_limit=10.0)

    @property
    def length(self) -> float:
        return float(LineString(self.points).length)


@dataclass(frozen=True, eq=False)
class Obstacle:
    """A solid shape. kind: 'polygon' | 'circle' | 'box'; params: the YAML values."""

    kind: str
    params: dict
    polygon: BaseGeometry


def make_obstacle(kind: str, params: dict) -> Obstacle:
    """Obstacle from already-validated YAML values (see worlds.load)."""
    if kind == "polygon":
        poly = Polygon(np.asarray(params["points"], dtype=float))
    elif kind == "circle":
        if params.get("sides") is not None:   # a regular polygon: fewer segments to ray cast
            a = 2.0 * np.pi * np.arange(int(params["sides"])) / int(params["sides"])
            ring = np.asarray(params["center"]) + params["radius"] * np.stack([np.cos(a), np.sin(a)], 1)
            poly = Polygon(ring)
        else:
            poly = Point(params["center"]).buffer(params["radius"], quad_segs=_CIRCLE_QUAD_SEGS)
    elif kind == "box":
        cx, cy = params["center"]
        sx, sy = params["size"]
        yaw = params.get("yaw", 0.0)
        corners = np.array([[-sx / 2, -sy / 2], [sx / 2, -sy / 2], [sx / 2, sy / 2], [-sx / 2, sy / 2]])
        c, s = np.cos(yaw), np.sin(yaw)
        corners = corners @ np.array([[c, s], [-s, c]]) + np.array([cx, cy])
        poly = Polygon(corners)
    else:
        raise ValueError(f"unknown obstacle kind {kind!r}")
    return Obstacle(kind, dict(params), poly)


def ring_segments(geometry: BaseGeometry) -> np.ndarray:
    """(S, 4) float64 x0, y0, x1, y1 of every edge of the rings of a (multi)polygon."""
    polys = geometry.geoms if isinstance(geometry, MultiPolygon) else [geometry]
    segs = []
    for poly in polys:
        if poly.is_empty:
            continue
        for ring in [poly.exterior, *poly.interiors]:
            xy = np.asarray(ring.coords, dtype=np.float64)
            segs.append(np.hstack([xy[:-1], xy[1:]]))
    return np.vstack(segs) if segs else np.zeros((0, 4))


@dataclass(frozen=True, eq=False)
class World:
    """A world: walls, obstacles, start pose (x, y, yaw) and an optional route ((K, 2) m)."""

    name: str
    walls: tuple[Wall, ...]
    obstacles: tuple[Obstacle, ...] = ()
    start: np.ndarray = field(default_factory=lambda: np.zeros(3))
    route: np.ndarray | None = None
    description: str = ""
    resolution: float = 0.05
    source: str = ""  # the file it came from, for messages

    @cached_property
    def solid(self) -> BaseGeometry:
        """Union of all wall and obstacle polygons (shapely)."""
        parts = [w.polygon for w in self.walls] + [o.polygon for o in self.obstacles]
        return shapely.union_all(parts) if parts else Polygon()

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the solid geometry."""
        return tuple(float(v) for v in self.solid.bounds)

    @property
    def wall_length(self) -> float:
        """Total centre-line length of the walls (m)."""
        return float(sum(w.length for w in self.walls))

    @cached_property
    def segments(self) -> np.ndarray:
        """(S, 4) float64 x0, y0, x1, y1 of every edge of the solid's boundary (for ray casting)."""
        return ring_segments(self.solid)

    @cached_property
    def visible_segments(self) -> np.ndarray:
        """(S, 4) float64 x0, y0, x1, y1 of the boundary of free_space: every wall and obstacle
        surface a lidar on the robot can see (the surfaces worlds.raster marks)."""
        return ring_segments(self.free_space)

    @cached_property
    def free_space(self) -> BaseGeometry:
        """The free region enclosed by walls that contains the start (shapely polygon)."""
        holes = []
        polys = self.solid.geoms if isinstance(self.solid, MultiPolygon) else [self.solid]
        start = Point(self.start[0], self.start[1])
        for poly in polys:
            for ring in poly.interiors:
                hole = Polygon(ring)
                if hole.contains(start):
                    holes.append(hole.difference(self.solid))
        if not holes:
            return Polygon()
        region = min(holes, key=lambda g: g.area)
        if isinstance(region, MultiPolygon):
            region = next(g for g in region.geoms if g.contains(start))
        return region
