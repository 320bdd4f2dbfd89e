"""Hand-built maps for the metrics tests: walls drawn as segments onto grids."""
from __future__ import annotations

import numpy as np

from slam.pose import inverse, transform_points
from worlds.grid import Grid

# an asymmetric room (no rotational symmetry): outer walls, an L-shaped inner wall,
# a short stub and a pillar, 6 m x 5 m
ROOM = [
    ((0.0, 0.0), (6.0, 0.0)), ((6.0, 0.0), (6.0, 5.0)), ((6.0, 5.0), (0.0, 5.0)),
    ((0.0, 5.0), (0.0, 0.0)),
    ((1.5, 1.0), (1.5, 3.5)), ((1.5, 3.5), (3.0, 3.5)),
    ((4.0, 0.0), (4.0, 1.8)),
    ((4.5, 3.5), (5.0, 3.5)), ((5.0, 3.5), (5.0, 4.0)), ((5.0, 4.0), (4.5, 4.0)), ((4.5, 4.0), (4.5, 3.5)),
]


def draw(segments, pose=(0.0, 0.0, 0.0), resolution=0.05, margin=0.5, free=True,
         origin=None, shape=None) -> Grid:
    """A grid with the cells under `segments` (world m) occupied (1.0), seen in the frame `pose`.

    pose: the map frame in the world, so a point p of the world appears at inverse(pose) (+) p.
    free: other cells inside the drawn area 0.0, else NaN. origin/shape: the grid geometry
    (default: bounding box of the transformed walls plus `margin`).
    """
    inv = inverse(np.asarray(pose, dtype=np.float64))
    pts = []
    for a, b in segments:
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = int(np.ceil(np.linalg.norm(b - a) / (resolution / 8))) + 1
        s = np.linspace(0.0, 1.0, n)[:, None]
        pts.append(a + s * (b - a))
    pts = transform_points(inv, np.concatenate(pts))
    if origin is None:
        # half-cell offset: walls on whole metres then run through cell centres, not along
        # cell borders where floor() would bias them by half a cell
        lo = np.floor((pts.min(0) - margin) / resolution) * resolution - resolution / 2
        hi = pts.max(0) + margin
        origin = (lo[0], lo[1], 0.0)
        shape = tuple(int(v) for v in np.ceil((hi - lo)[::-1] / resolution))
    prob = np.full(shape, 0.0 if free else np.nan)
    g = Grid(prob, resolution, np.asarray(origin, float))
    r, c = g.world_to_cell(pts)
    ok = g.in_bounds(r, c)
    prob[r[ok], c[ok]] = 1.0
    return Grid(prob, resolution, g.origin)
