"""Gauss-Newton refinement of a particle's matched pose on its own count map (Hector's matcher,
Kohlbrecher et al. 2011, inside Gmapping's improved proposal; Grisetti et al. 2007 leave the
scan matcher open, and the benchmark's issue names "the same Gauss-Newton matcher").

Gmapping's hill climb scores a beam by exp(-d^2 / sigma) against the nearest mean hit point of
the occupied cells around it; with the LDS-01's range noise (2.5 % of the range) that score is
flat within a cell, and the climb stops centimetres and degrees off. The refinement reads the
particle's count map as a reflectance map, M = hits / visits per cell (0 where nothing was
seen, hector_slam's GridMapReflectanceCount), interpolated bilinearly, and runs Hector's
Gauss-Newton steps on sum_i (1 - M(S_i(pose)))^2 from the hill climb's pose, coarse levels
(counts pooled 2 x 2 per level) first, with the motion prior added as a quadratic pull
(slam.pf.refine_pose, through gn's match_scan).

reflectance_patch: compiled; reflectance_patch_ref: numpy, for tests.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["reflectance_patch", "reflectance_patch_ref"]


@njit(cache=True)
def reflectance_patch(table, pool, grid_meta, box, factor):
    """hits / visits over a box of cells of one particle's tiled map, cells pooled factor x
    factor (sum of hits over sum of visits), 0 where nothing was visited.

    table: (TR, TC) int32 tile indices (-1: none); pool: (cap, T, T, 4) float32 counters
    (hits, visits, ...); grid_meta: (6,) ox, oy, res, rows, cols, tile; box: (4,) int64 first
    row, first column, rows, columns. Returns (ceil(rows / factor), ceil(cols / factor))
    float64; a partial last row or column of pooled cells pools fewer cells.
    """
    rows, cols, tile = int(grid_meta[3]), int(grid_meta[4]), int(grid_meta[5])
    r0, c0, nr, nc = box[0], box[1], box[2], box[3]
    out_r = (nr + factor - 1) // factor
    out_c = (nc + factor - 1) // factor
    hits = np.zeros((out_r, out_c))
    visits = np.zeros((out_r, out_c))
    for i in range(nr):
        r = r0 + i
        if r < 0 or r >= rows:
            continue
        tr = r // tile
        lr = r - tr * tile
        for j in range(nc):
            c = c0 + j
            if c < 0 or c >= cols:
                continue
            tc = c // tile
            t = table[tr, tc]
            if t < 0:
                continue
            lc = c - tc * tile
            hits[i // factor, j // factor] += pool[t, lr, lc, 0]
            visits[i // factor, j // factor] += pool[t, lr, lc, 1]
    out = np.zeros((out_r, out_c))
    for i in range(out_r):
        for j in range(out_c):
            if visits[i, j] > 0:
                out[i, j] = hits[i, j] / visits[i, j]
    return out


def reflectance_patch_ref(dense: np.ndarray, box, factor: int) -> np.ndarray:
    """Reference on dense counters (rows, cols, 4): slice, zero-pad, pool by reshaping."""
    r0, c0, nr, nc = (int(v) for v in box)
    rows, cols = dense.shape[:2]
    hv = np.zeros((nr, nc, 2))
    rr0, rr1 = max(r0, 0), min(r0 + nr, rows)
    cc0, cc1 = max(c0, 0), min(c0 + nc, cols)
    if rr1 > rr0 and cc1 > cc0:
        hv[rr0 - r0:rr1 - r0, cc0 - c0:cc1 - c0] = dense[rr0:rr1, cc0:cc1, :2]
    hv = np.pad(hv, ((0, -nr % factor), (0, -nc % factor), (0, 0)))
    s = hv.reshape(hv.shape[0] // factor, factor, hv.shape[1] // factor, factor, 2).sum(axis=(1, 3))
    visited = s[..., 1] > 0
    return np.where(visited, s[..., 0] / np.where(visited, s[..., 1], 1.0), 0.0)
