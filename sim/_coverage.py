"""Cells holding the ends of lidar beams: a numba kernel and a plain numpy reference.

mark_beam_ends_inplace: compiled, one pass over the beams, no temporary arrays;
mark_beam_ends_ref: the same statement in vectorised numpy, for tests.
A beam ends on a wall surface; a surface on a cell edge belongs to the cells on both
sides (worlds.raster takes the floor), so each beam marks the cells of the points `eps`
before and after its end. Cell convention as worlds.Grid.world_to_cell.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["mark_beam_ends_inplace", "mark_beam_ends_ref"]


@njit(cache=True, nogil=True)
def mark_beam_ends_inplace(hit, grid_frame, origins, ranges, beams, cos_a, sin_a, eps):
    """Set hit[row, col] = True for the cells of the points ranges[i] -+ eps along beam i.

    hit: (rows, cols) bool, changed in place; grid_frame: (5,) [ox, oy, resolution,
    cos(yaw), sin(yaw)] of the grid's origin; origins: (R, 2) m; ranges: (R,) m;
    beams: (K,) int64 indices into origins / ranges of the beams to mark; cos_a, sin_a:
    (K,) cos and sin of those beams' world angles; eps: m.
    """
    gx = grid_frame[0]
    gy = grid_frame[1]
    res = grid_frame[2]
    c = grid_frame[3]
    s = grid_frame[4]
    rows = hit.shape[0]
    cols = hit.shape[1]
    for k in range(beams.shape[0]):
        i = beams[k]
        for side in range(2):
            r = ranges[i] - eps if side == 0 else ranges[i] + eps
            dx = (origins[i, 0] + r * cos_a[k]) - gx
            dy = (origins[i, 1] + r * sin_a[k]) - gy
            col = math.floor((c * dx + s * dy) / res)
            row = math.floor((-s * dx + c * dy) / res)
            if 0 <= row < rows and 0 <= col < cols:
                hit[int(row), int(col)] = True


def mark_beam_ends_ref(hit, grid_frame, origins, ranges, beams, cos_a, sin_a, eps):
    """Reference for mark_beam_ends_inplace (same arguments and effect), vectorised numpy."""
    gx, gy, res, c, s = grid_frame[:5]
    r = ranges[beams]
    ends = np.vstack([origins[beams] + (r - eps)[:, None] * np.stack([cos_a, sin_a], axis=1),
                      origins[beams] + (r + eps)[:, None] * np.stack([cos_a, sin_a], axis=1)])
    dx, dy = ends[:, 0] - gx, ends[:, 1] - gy
    cols = np.floor((c * dx + s * dy) / res).astype(np.int64)
    rows = np.floor((-s * dx + c * dy) / res).astype(np.int64)
    keep = (rows >= 0) & (rows < hit.shape[0]) & (cols >= 0) & (cols < hit.shape[1])
    hit[rows[keep], cols[keep]] = True
