"""Per-particle count maps in copy-on-write tiles (Gmapping's PointAccumulator cells).

Each cell holds Gmapping's counters: hits n, visits, and the sum of the hit points
(relative to the cell's lower-left corner, so float32 stays precise far from the origin).
Occupancy = n / visits (unknown when visits == 0); the mean hit point = corner + sum / n.

Storage: a pool of tiles `pool[tile, row_in_tile, col_in_tile, field]` (float32, fields
0 hits, 1 visits, 2 sum dx, 3 sum dy) and per particle a table `tables[p, tile_row,
tile_col]` of pool indices (-1 = never touched). Particles that descend from the same
ancestor share the tiles neither has written since; a tile is copied only when a particle
writes into a tile that another particle also uses (copy on write, as Gmapping shares
its map patches through reference-counted pointers).

grid_meta = [ox, oy, resolution, rows, cols, tile]: world x, y of the lower-left corner
of cell (0, 0), metres per cell, the cell counts of the whole table, cells per tile side.

Kernels (compiled) and their plain references (dense arrays, brute force):
  ray_cells        Amanatides-Woo cell walk      <-> ray_cells_ref (segment/box clipping)
  mark_touched     tiles a scan insertion writes
  privatize        copy-on-write of the marked tiles
  insert_scans     count updates along the beams <-> insert_scan_ref (dense counters)
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from slam._kernels.insert import axis_walk

__all__ = ["N_FIELDS", "ray_cells", "mark_touched", "privatize", "insert_scans",
           "beam_world", "ray_cells_ref", "insert_scan_ref"]

N_FIELDS = 4


@njit(cache=True, nogil=True)
def ray_cells(u0, v0, u1, v1, out_c, out_r):
    """Cells crossed by the segment (u0, v0) -> (u1, v1) in cell units, start to end.

    Amanatides & Woo's traversal: visits exactly the cells the segment passes through.
    out_c, out_r: (M,) int64 scratch, M >= |dc| + |dr| + 1. Returns the number written.
    """
    c = int(math.floor(u0))
    r = int(math.floor(v0))
    ce = int(math.floor(u1))
    re = int(math.floor(v1))
    du = u1 - u0
    dv = v1 - v0
    step_c, t_delta_c, t_max_c = axis_walk(u0, c, du)
    step_r, t_delta_r, t_max_r = axis_walk(v0, r, dv)
    n_steps = abs(ce - c) + abs(re - r)
    out_c[0] = c
    out_r[0] = r
    n = 1
    for _ in range(n_steps):
        # the step count is fixed so rounding can never walk past the end cell
        if (t_max_c < t_max_r and c != ce) or r == re:
            c += step_c
            t_max_c += t_delta_c
        else:
            r += step_r
            t_max_r += t_delta_r
        out_c[n] = c
        out_r[n] = r
        n += 1
    return n


@njit(cache=True, nogil=True)
def beam_world(pose, origin, ends):
    """Lidar origin (2,) and beam ends (K, 2) in the world for robot pose (3,).

    origin: (2,) lidar position in the robot frame; ends: (K, 2) robot frame, m.
    """
    c = math.cos(pose[2])
    s = math.sin(pose[2])
    o = np.empty(2)
    o[0] = pose[0] + c * origin[0] - s * origin[1]
    o[1] = pose[1] + s * origin[0] + c * origin[1]
    w = np.empty_like(ends)
    for k in range(ends.shape[0]):
        w[k, 0] = pose[0] + c * ends[k, 0] - s * ends[k, 1]
        w[k, 1] = pose[1] + s * ends[k, 0] + c * ends[k, 1]
    return o, w


@njit(cache=True, nogil=True)
def ray_buffer_len(poses, origin, ends, res):
    """Cells the longest ray of any pose can cross (Manhattan length in cells + margin)."""
    m = 4
    for p in range(poses.shape[0]):
        o, w = beam_world(poses[p], origin, ends)
        for k in range(w.shape[0]):
            need = int(abs(w[k, 0] - o[0]) / res + abs(w[k, 1] - o[1]) / res) + 4
            if need > m:
                m = need
    return m


@njit(cache=True, nogil=True)
def mark_touched(n_tile_rows, n_tile_cols, grid_meta, poses, origin, ends):
    """(N, TR, TC) bool: the tiles that inserting `ends` at each of `poses` writes to.

    poses: (N, 3) robot poses; origin: (2,) lidar in the robot frame; ends: (K, 2) robot frame.
    """
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols, tile = int(grid_meta[3]), int(grid_meta[4]), int(grid_meta[5])
    n = poses.shape[0]
    mask = np.zeros((n, n_tile_rows, n_tile_cols), dtype=np.bool_)
    m = ray_buffer_len(poses, origin, ends, res)
    buf_c = np.empty(m, dtype=np.int64)
    buf_r = np.empty(m, dtype=np.int64)
    for p in range(n):
        o, w = beam_world(poses[p], origin, ends)
        u0 = (o[0] - ox) / res
        v0 = (o[1] - oy) / res
        for k in range(w.shape[0]):
            cnt = ray_cells(u0, v0, (w[k, 0] - ox) / res, (w[k, 1] - oy) / res, buf_c, buf_r)
            for i in range(cnt):
                c = buf_c[i]
                r = buf_r[i]
                if 0 <= r < rows and 0 <= c < cols:
                    mask[p, r // tile, c // tile] = True
    return mask


@njit(cache=True, nogil=True)
def privatize(tables, pool, refcount, todo, free_slots):
    """Give each (p, tile_row, tile_col) of `todo` a tile of its own, in place.

    tables: (N, TR, TC) int32; pool: (cap, T, T, 4) float32; refcount: (cap,) int32 (number
    of table entries pointing at each tile); todo: (M, 3) int64; free_slots: (F,) int64
    unused pool indices, F >= M. A shared tile is copied, a missing one zeroed; a tile whose
    other users already copied it away is kept. Returns the number of free slots used.
    """
    used = 0
    for j in range(todo.shape[0]):
        p, tr, tc = todo[j, 0], todo[j, 1], todo[j, 2]
        old = tables[p, tr, tc]
        if old >= 0 and refcount[old] == 1:
            continue
        new = free_slots[used]
        used += 1
        if old >= 0:
            pool[new] = pool[old]
            refcount[old] -= 1
        else:
            pool[new] = 0.0
        refcount[new] = 1
        tables[p, tr, tc] = new
    return used


@njit(cache=True, nogil=True)
def insert_scans(tables, pool, grid_meta, poses, origin, ends, hit):
    """Count one scan into each particle's map, in place (Gmapping's registerScan).

    Every cell a beam crosses before its end gets a visit; the end cell of a beam with a
    return (hit[k]) gets a visit, a hit and the hit point. Cells outside the table are
    skipped. The tiles written must be private (see mark_touched / privatize).
    tables: (N, TR, TC) int32; pool: (cap, T, T, 4) float32; poses: (N, 3);
    origin: (2,) lidar in the robot frame; ends: (K, 2) beam ends, robot frame; hit: (K,) bool.
    """
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols, tile = int(grid_meta[3]), int(grid_meta[4]), int(grid_meta[5])
    n = poses.shape[0]
    m = ray_buffer_len(poses, origin, ends, res)
    buf_c = np.empty(m, dtype=np.int64)
    buf_r = np.empty(m, dtype=np.int64)
    for p in range(n):
        o, w = beam_world(poses[p], origin, ends)
        u0 = (o[0] - ox) / res
        v0 = (o[1] - oy) / res
        for k in range(w.shape[0]):
            cnt = ray_cells(u0, v0, (w[k, 0] - ox) / res, (w[k, 1] - oy) / res, buf_c, buf_r)
            for i in range(cnt):
                c = buf_c[i]
                r = buf_r[i]
                if r < 0 or r >= rows or c < 0 or c >= cols:
                    continue
                t = tables[p, r // tile, c // tile]
                if t < 0:
                    continue
                lr = r % tile
                lc = c % tile
                pool[t, lr, lc, 1] += 1.0
                if i == cnt - 1 and hit[k]:
                    pool[t, lr, lc, 0] += 1.0
                    pool[t, lr, lc, 2] += w[k, 0] - (ox + c * res)
                    pool[t, lr, lc, 3] += w[k, 1] - (oy + r * res)


# --- references ---------------------------------------------------------------------------

def ray_cells_ref(u0: float, v0: float, u1: float, v1: float) -> set[tuple[int, int]]:
    """Set of (col, row) cells whose square the segment crosses with positive length
    (Liang-Barsky clipping of the segment against every cell of its bounding box)."""
    out = set()
    for c in range(int(np.floor(min(u0, u1))), int(np.floor(max(u0, u1))) + 1):
        for r in range(int(np.floor(min(v0, v1))), int(np.floor(max(v0, v1))) + 1):
            t0, t1 = 0.0, 1.0
            ok = True
            for d, lo, hi, s in ((u1 - u0, c, c + 1, u0), (v1 - v0, r, r + 1, v0)):
                if d == 0:
                    if not (lo <= s < hi):
                        ok = False
                    continue
                a, b = (lo - s) / d, (hi - s) / d
                t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
            if ok and t1 - t0 > 1e-12:
                out.add((c, r))
    return out


def insert_scan_ref(counts: np.ndarray, grid_meta: np.ndarray, pose: np.ndarray,
                    origin: np.ndarray, ends: np.ndarray, hit: np.ndarray) -> None:
    """Dense statement of insert_scans for one pose: counts (rows, cols, 4) float64, in place."""
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols = int(grid_meta[3]), int(grid_meta[4])
    c, s = np.cos(pose[2]), np.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    o = pose[:2] + rot @ origin
    for e, h in zip(ends, hit):
        w = pose[:2] + rot @ e
        u0, v0 = (o - (ox, oy)) / res
        u1, v1 = (w - (ox, oy)) / res
        end = (int(np.floor(u1)), int(np.floor(v1)))
        for cc, rr in ray_cells_ref(u0, v0, u1, v1) | {end, (int(np.floor(u0)), int(np.floor(v0)))}:
            if not (0 <= rr < rows and 0 <= cc < cols):
                continue
            counts[rr, cc, 1] += 1
            if h and (cc, rr) == end:
                counts[rr, cc, 0] += 1
                counts[rr, cc, 2] += w[0] - (ox + cc * res)
                counts[rr, cc, 3] += w[1] - (oy + rr * res)
