"""Wall coverage: which share of the true wall cells a lidar sees from a path.

A wall cell (occupied in the ground truth, worlds.raster) counts as seen when a beam from
some point of the path, sampled every `step` m, ends in it within max_range; beams are
exact ray casts against the walls (worlds.visibility), 2048 per revolution.
"""
from __future__ import annotations

import numpy as np

from worlds.grid import Grid
from worlds.model import World
from worlds.raster import rasterize
from worlds.visibility import seen_mask

__all__ = ["wall_coverage", "resample_path", "seen_wall_cells", "seen_share", "occupied_share"]


def resample_path(path_xy: np.ndarray, step: float = 0.1) -> np.ndarray:
    """(K, 2) polyline -> (M, 2) points at most `step` m apart, vertices kept, in order."""
    path = np.asarray(path_xy, dtype=np.float64).reshape(-1, 2)
    if len(path) < 2:
        return path.copy()
    out = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + (np.arange(1, n + 1)[:, None] / n) * (b - a))
    return np.vstack(out)


def seen_wall_cells(world: World, path_xy: np.ndarray, max_range: float = 3.0, step: float = 0.1,
                    truth: Grid | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(seen, walls): (rows, cols) bool masks on the ground-truth grid: occupied cells seen
    from the path and all occupied cells."""
    truth = rasterize(world) if truth is None else truth
    walls = truth.occupied()
    pts = resample_path(path_xy, step)
    seen = seen_mask(truth, world.segments, pts, max_range) & walls
    return seen, walls


def wall_coverage(world: World, path_xy: np.ndarray, max_range: float = 3.0, step: float = 0.1) -> float:
    """Fraction of the ground truth's occupied cells that a lidar sees from the path.

    path_xy: (K, 2) m, a polyline (the start pose should be its first point);
    max_range: m; step: sampling of the path, m. Returns a float in [0, 1].
    """
    seen, walls = seen_wall_cells(world, path_xy, max_range, step)
    return float(seen.sum() / max(1, walls.sum()))


def seen_share(truth: Grid, points: np.ndarray) -> float:
    """Fraction of the occupied cells of `truth` that hold at least one of `points`.

    points: (P, 2) m, e.g. the ends of the beams a lidar cast. Returns a float in [0, 1].
    """
    rows, cols = truth.world_to_cell(np.asarray(points, dtype=np.float64).reshape(-1, 2))
    keep = truth.in_bounds(rows, cols)
    hit = np.zeros(truth.shape, dtype=bool)
    hit[rows[keep], cols[keep]] = True
    return occupied_share(truth, hit)


def occupied_share(truth: Grid, marked: np.ndarray) -> float:
    """Fraction of the occupied cells of `truth` that are True in `marked` (truth's shape)."""
    walls = truth.occupied()
    return float((marked & walls).sum() / max(1, walls.sum()))
