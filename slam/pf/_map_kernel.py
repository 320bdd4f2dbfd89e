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

grid_meta = [ox, oy, resolution, rows, cols, shift]: world x, y of the lower-left corner
of cell (0, 0), metres per cell, the cell counts of the whole table, and log2 of the cells
per tile side (tiles are 2^shift cells wide, so a cell's tile and place in it are shifts and
masks, not divisions, on the kernels' hottest path).

Kernels (compiled) and their plain references (dense arrays, brute force):
  patch_box        the box of cells a particle's scan matching reads
  narrow_box       the cells around the scan's end points, inside that box
  read_patch       one particle's map over a box as dense arrays (read inside a narrower
                   one) <-> read_patch_ref
  ray_cells        Amanatides-Woo cell walk      <-> ray_cells_ref (segment/box clipping)
  tiles_bound      how many tiles a scan insertion can make a particle's own
  insert_scans     count updates along the beams, copying shared tiles on first write
                   <-> insert_scan_ref (dense counters)
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from slam._kernels.insert import axis_walk

__all__ = ["N_FIELDS", "patch_box", "narrow_box", "read_patch", "read_patch_ref", "ray_cells",
           "tiles_bound", "insert_scans", "beam_world", "ray_cells_ref", "insert_scan_ref"]

N_FIELDS = 4


@njit(cache=True, nogil=True)
def patch_box(table, grid_meta, pose, half, box):
    """Into box (4,) int64: first row, column, rows, columns of the cells within `half` cells
    of pose (3,), clipped to the bounding box of the tiles the particle's table (TR, TC)
    has written."""
    ox, oy, res, shift = grid_meta[0], grid_meta[1], grid_meta[2], int(grid_meta[5])
    r = int(math.floor((pose[1] - oy) / res))
    c = int(math.floor((pose[0] - ox) / res))
    r0, r1, c0, c1 = r - half, r + half, c - half, c + half
    a0, a1, b0, b1 = table.shape[0], -1, table.shape[1], -1
    for a in range(table.shape[0]):
        for b in range(table.shape[1]):
            if table[a, b] >= 0:
                a0, a1 = min(a0, a), max(a1, a)
                b0, b1 = min(b0, b), max(b1, b)
    if a1 >= 0:
        r0, r1 = max(r0, a0 << shift), min(r1, (a1 + 1) << shift)
        c0, c1 = max(c0, b0 << shift), min(c1, (b1 + 1) << shift)
    box[0], box[1], box[2], box[3] = r0, c0, max(r1 - r0, 0), max(c1 - c0, 0)


@njit(cache=True, nogil=True)
def narrow_box(grid_meta, pose, points, room, box):
    """Cut box (4,) int64 (first row, column, rows, columns) down to the cells within `room`
    cells of the bounding box of points (K, 2, robot frame, m) placed at pose (3,).

    The scan matching reads the cells around the end points at the poses it tries, which stay
    within a few centimetres of the start. On swirl_l the square around the pose out to the
    farthest return, clipped to the tiles written (patch_box), holds about twice as many cells
    as the returns' bounding box grown by 0.5 m, the square itself about four times."""
    if points.shape[0] == 0:
        return
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    x_lo = y_lo = np.inf
    x_hi = y_hi = -np.inf
    for k in range(points.shape[0]):
        x = pose[0] + c * points[k, 0] - s * points[k, 1]
        y = pose[1] + s * points[k, 0] + c * points[k, 1]
        x_lo, x_hi = min(x_lo, x), max(x_hi, x)
        y_lo, y_hi = min(y_lo, y), max(y_hi, y)
    r0 = max(box[0], int(math.floor((y_lo - oy) / res)) - room)
    c0 = max(box[1], int(math.floor((x_lo - ox) / res)) - room)
    r1 = min(box[0] + box[2], int(math.floor((y_hi - oy) / res)) + room + 1)
    c1 = min(box[1] + box[3], int(math.floor((x_hi - ox) / res)) + room + 1)
    box[0], box[1], box[2], box[3] = r0, c0, max(r1 - r0, 0), max(c1 - c0, 0)


@njit(cache=True, nogil=True)
def read_patch(table, pool, grid_meta, box, inner, prob, hits, mean_off):
    """One particle's counters over box (first row, column, rows, columns) as dense float32
    arrays, into the first rows x columns of prob, hits (R, C) and mean_off (R, C, 2):
    hits / visits (0 where unvisited), the hit count, and the mean hit point's offset (m)
    from the cell's lower-left corner (0 where no hit). Cells outside the grid or in tiles
    never written read as unvisited.

    Only the cells of box inside `inner` (a box of the same form) are read; the others get
    prob 0 and keep whatever hits and mean_off held (the matcher reads those two only where
    prob is above the fullness threshold, which is >= 0)."""
    rows, cols, shift = int(grid_meta[3]), int(grid_meta[4]), int(grid_meta[5])
    in_tile = (1 << shift) - 1
    r0, c0 = box[0], box[1]
    # inner's rows and columns in the patch, clipped to it
    i0, i1 = max(inner[0] - r0, 0), min(inner[0] + inner[2] - r0, box[2])
    j0, j1 = max(inner[1] - c0, 0), min(inner[1] + inner[3] - c0, box[3])
    for i in range(box[2]):
        if i < i0 or i >= i1:
            prob[i, :box[3]] = 0.0
            continue
        prob[i, :j0] = 0.0
        prob[i, j1:box[3]] = 0.0
        r = r0 + i
        for j in range(j0, j1):
            c = c0 + j
            t = -1
            if 0 <= r < rows and 0 <= c < cols:
                t = table[r >> shift, c >> shift]
            h = v = np.float32(0.0)
            if t >= 0:
                h = pool[t, r & in_tile, c & in_tile, 0]
                v = pool[t, r & in_tile, c & in_tile, 1]
            prob[i, j] = h / v if v > 0 else 0.0
            hits[i, j] = h
            if h > 0:
                mean_off[i, j, 0] = pool[t, r & in_tile, c & in_tile, 2] / h
                mean_off[i, j, 1] = pool[t, r & in_tile, c & in_tile, 3] / h
            else:
                mean_off[i, j, 0] = mean_off[i, j, 1] = 0.0


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
def tiles_bound(grid_meta, poses, origin, ends):
    """An upper bound of the tiles inserting `ends` at `poses` can write: per particle, the
    tiles of the bounding box of its lidar origin and beam ends (the free pool slots
    insert_scans may need)."""
    ox, oy, res, shift = grid_meta[0], grid_meta[1], grid_meta[2], int(grid_meta[5])
    total = 0
    for p in range(poses.shape[0]):
        o, w = beam_world(poses[p], origin, ends)
        x0, x1, y0, y1 = o[0], o[0], o[1], o[1]
        for k in range(w.shape[0]):
            x0, x1 = min(x0, w[k, 0]), max(x1, w[k, 0])
            y0, y1 = min(y0, w[k, 1]), max(y1, w[k, 1])
        c0 = int(math.floor((x0 - ox) / res)) >> shift
        c1 = int(math.floor((x1 - ox) / res)) >> shift
        r0 = int(math.floor((y0 - oy) / res)) >> shift
        r1 = int(math.floor((y1 - oy) / res)) >> shift
        # one tile of slack on each side: a ray's cell walk may round across a tile edge
        total += (c1 - c0 + 3) * (r1 - r0 + 3)
    return total


@njit(cache=True, nogil=True)
def _own_tile(tables, pool, refcount, free_slots, used, p, tr, tc):
    """Particle p's tile (tr, tc) made its own before it writes into it: a shared tile is
    copied, a missing one zeroed, one no other particle uses kept. Returns (its pool index,
    the free slots used so far)."""
    old = tables[p, tr, tc]
    if old >= 0 and refcount[old] == 1:
        return old, used
    new = free_slots[used]
    if old >= 0:
        # element loop, not pool[new] = pool[old]: numba compiles the slice copy's
        # shape-mismatch message (string formatting, ~2 s of a cold start) for no use here
        src, dst = pool[old], pool[new]
        for i in range(dst.shape[0]):
            for j in range(dst.shape[1]):
                for q in range(dst.shape[2]):
                    dst[i, j, q] = src[i, j, q]
        refcount[old] -= 1
    else:
        pool[new] = 0.0
    refcount[new] = 1
    tables[p, tr, tc] = new
    return new, used + 1


@njit(cache=True, nogil=True)
def insert_scans(tables, pool, refcount, free_slots, grid_meta, poses, origin, ends, hit):
    """Count one scan into each particle's map, in place (Gmapping's registerScan).

    Every cell a beam crosses before its end gets a visit; the end cell of a beam with a
    return (hit[k]) gets a visit, a hit and the hit point. Cells outside the table are
    skipped. A tile is made the particle's own (copy on write, _own_tile) the first time
    it writes into it, taking slots from free_slots (unused pool indices, at least
    tiles_bound of them). tables: (N, TR, TC) int32; pool: (cap, T, T, 4) float32;
    refcount: (cap,) int32 table entries per tile; poses: (N, 3); origin: (2,) lidar in
    the robot frame; ends: (K, 2) beam ends, robot frame; hit: (K,) bool. Returns the
    number of free slots used.
    """
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols, shift = int(grid_meta[3]), int(grid_meta[4]), int(grid_meta[5])
    in_tile = (1 << shift) - 1
    n = poses.shape[0]
    m = ray_buffer_len(poses, origin, ends, res)
    buf_c = np.empty(m, dtype=np.int64)
    buf_r = np.empty(m, dtype=np.int64)
    used = 0
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
                t = tables[p, r >> shift, c >> shift]
                if t < 0 or refcount[t] != 1:
                    t, used = _own_tile(tables, pool, refcount, free_slots, used, p, r >> shift,
                                        c >> shift)
                lr = r & in_tile
                lc = c & in_tile
                pool[t, lr, lc, 1] += 1.0
                if i == cnt - 1 and hit[k]:
                    pool[t, lr, lc, 0] += 1.0
                    pool[t, lr, lc, 2] += w[k, 0] - (ox + c * res)
                    pool[t, lr, lc, 3] += w[k, 1] - (oy + r * res)
    return used


# --- references ---------------------------------------------------------------------------

def read_patch_ref(dense: np.ndarray, box) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """read_patch on dense counters (rows, cols, 4): (prob, hits, mean_off) of the box."""
    r0, c0, nr, nc = (int(v) for v in box)
    rows, cols = dense.shape[:2]
    cnt = np.zeros((nr, nc, 4), dtype=np.float32)
    rr0, rr1 = max(r0, 0), min(r0 + nr, rows)
    cc0, cc1 = max(c0, 0), min(c0 + nc, cols)
    if rr1 > rr0 and cc1 > cc0:
        cnt[rr0 - r0:rr1 - r0, cc0 - c0:cc1 - c0] = dense[rr0:rr1, cc0:cc1]
    h, v = cnt[..., 0], cnt[..., 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        prob = np.where(v > 0, h / v, np.float32(0))
        off = np.where(h[..., None] > 0, cnt[..., 2:] / h[..., None], np.float32(0))
    return prob.astype(np.float32), h.copy(), off.astype(np.float32)


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
