"""The final map of the pose-graph SLAM: every node's scan re-inserted at its optimized pose.

Two ways (GraphConfig.final_map):
- "probability": one probability grid with the submaps' hit/miss odds (Cartographer's map,
  equivalent to composing the submaps at their optimized poses).
- "sharpened" (ours): the LDS-01's range error grows with range (2.5 % of the range, 1 sigma),
  so a wall seen from afar spreads its hits over the cells in front of and behind it, and
  with hit odds 0.55 / miss odds 0.49 a cell hit by one beam in six ends up occupied. Here
  each cell keeps a hit weight H and a pass weight F, each ray weighted by
  min(1, (near_range / range)^2) (inverse variance of its range); a cell is occupied with
  probability H / (H + F), and cells whose H is below `suppress_ratio` times the largest H of
  their 3x3 neighbourhood (the spill behind a wall, which no ray ever passes) are capped at 0.5.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter

from worlds.grid import Grid
from slam._kernels.insert import insert_rays_inplace
from slam.pose import transform_points

__all__ = ["sharpened_map"]

_BANDS = np.array([0.0, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, np.inf])


def sharpened_map(poses: np.ndarray, scans: list, resolution: float, near_range: float = 0.5,
                  suppress_ratio: float = 0.4, max_range: float = 0.0) -> Grid:
    """poses: (N, 3) optimized node poses; scans: N (origin (2,), hits (H, 2), misses (M, 2))
    in the robot frame, m. Returns the map as a Grid (NaN where no ray went)."""
    world = []
    lo = np.array([np.inf, np.inf])
    hi = -lo
    for pose, (origin, hits, misses) in zip(poses, scans):
        o = transform_points(pose, origin[None, :])[0]
        h = transform_points(pose, hits)
        m = transform_points(pose, misses)
        rh = np.hypot(*(hits - origin).T)
        rm = np.hypot(*(misses - origin).T) if len(misses) else np.zeros(0)
        if max_range > 0:
            keep = rh <= max_range
            h, rh = h[keep], rh[keep]
        world.append((o, h, m, rh, rm))
        allp = np.vstack([o[None, :], h, m])
        lo = np.minimum(lo, allp.min(axis=0))
        hi = np.maximum(hi, allp.max(axis=0))
    ox, oy = np.floor(lo / resolution - 2) * resolution
    cols = int(np.ceil((hi[0] - ox) / resolution)) + 2
    rows = int(np.ceil((hi[1] - oy) / resolution)) + 2
    meta = np.array([ox, oy, resolution, rows, cols], np.float64)
    H = np.full((rows, cols), np.nan)
    F = np.full((rows, cols), np.nan)
    big = 1e300
    for o, h, m, rh, rm in world:
        ends = np.vstack([h, m])
        rng = np.concatenate([rh, rm])
        hit = np.zeros(len(ends), bool)
        hit[:len(h)] = True
        band = np.digitize(rng, _BANDS) - 1
        for b in np.unique(band):
            sel = band == b
            mid = 0.5 * (_BANDS[b] + min(_BANDS[b + 1], 3.5))
            w = min(1.0, (near_range / max(mid, 1e-6)) ** 2)
            e = np.ascontiguousarray(ends[sel])
            hm = np.ascontiguousarray(hit[sel])
            insert_rays_inplace(H, meta, o, e, hm, 0.0, w, -big, big)
            insert_rays_inplace(F, meta, o, e, hm, w, 0.0, -big, big)
    known = ~np.isnan(H)
    Hz = np.nan_to_num(H, nan=0.0)
    Fz = np.nan_to_num(F, nan=0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = np.where(Hz + Fz > 0, Hz / (Hz + Fz), 0.5)
    suppressed = Hz < suppress_ratio * maximum_filter(Hz, size=3)
    p = np.where(suppressed, np.minimum(p, 0.5), p)
    p[~known] = np.nan
    return Grid(p, resolution, np.array([ox, oy, 0.0]))
