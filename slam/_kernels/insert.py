"""Log-odds ray insertion into an occupancy grid (exact cell traversal, Amanatides & Woo 1987).

insert_rays_inplace: compiled; insert_rays_ref: an independent numpy statement of the same
update (cells found from the sorted crossings of each segment with the grid lines), for tests.

Update rule for one scan (as Hector's and Cartographer's "each cell once per scan", hits first):
every cell holding the end point of a hit ray gets `l_occ` once; every other cell crossed by
any ray (from the sensor origin to the end point; for a no-return ray the end cell too) gets
`l_free` once. A cell hit in this scan is not also freed by it, so walls seen at grazing
angles are not eroded by neighbouring beams. Values are clamped to [l_min, l_max]; NaN means
"never touched" and counts as 0 before the update. Cells outside the grid are skipped.

grid_meta: (5,) [ox, oy, resolution, rows, cols]; logodds[row, col], row 0 at the bottom.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["insert_rays_inplace", "insert_rays_ref"]

# marks in the per-call scratch grid
_UNTOUCHED, _FREED, _HIT = 0, 1, 2


@njit(cache=True)
def _apply(logodds, r, c, l, l_min, l_max):
    v = logodds[r, c]
    if v != v:  # NaN: never touched
        v = 0.0
    v += l
    if v < l_min:
        v = l_min
    elif v > l_max:
        v = l_max
    logodds[r, c] = v


@njit(cache=True)
def insert_rays_inplace(logodds, grid_meta, origin_xy, ends_xy, hit_mask, l_free, l_occ, l_min, l_max):
    """Update `logodds` (rows, cols) in place with the rays origin_xy (2,) -> ends_xy (N, 2) (m).

    hit_mask: (N,) bool, True where the ray ended on an obstacle. Returns the number of cells updated.
    """
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols = int(grid_meta[3]), int(grid_meta[4])
    mark = np.zeros((rows, cols), dtype=np.uint8)
    n_upd = 0
    n = ends_xy.shape[0]
    # pass 1: hit cells
    for i in range(n):
        if not hit_mask[i]:
            continue
        c = int(np.floor((ends_xy[i, 0] - ox) / res))
        r = int(np.floor((ends_xy[i, 1] - oy) / res))
        if r < 0 or r >= rows or c < 0 or c >= cols or mark[r, c] == _HIT:
            continue
        mark[r, c] = _HIT
        _apply(logodds, r, c, l_occ, l_min, l_max)
        n_upd += 1
    # pass 2: free cells along every ray (exact traversal in map units)
    x0 = (origin_xy[0] - ox) / res
    y0 = (origin_xy[1] - oy) / res
    cx0 = int(np.floor(x0))
    cy0 = int(np.floor(y0))
    for i in range(n):
        x1 = (ends_xy[i, 0] - ox) / res
        y1 = (ends_xy[i, 1] - oy) / res
        ex = int(np.floor(x1))
        ey = int(np.floor(y1))
        dx = x1 - x0
        dy = y1 - y0
        cx, cy = cx0, cy0
        if dx > 0:
            sx = 1
            tdx = 1.0 / dx
            tmx = (cx + 1 - x0) * tdx
        elif dx < 0:
            sx = -1
            tdx = -1.0 / dx
            tmx = (x0 - cx) * tdx
        else:
            sx = 0
            tdx = np.inf
            tmx = np.inf
        if dy > 0:
            sy = 1
            tdy = 1.0 / dy
            tmy = (cy + 1 - y0) * tdy
        elif dy < 0:
            sy = -1
            tdy = -1.0 / dy
            tmy = (y0 - cy) * tdy
        else:
            sy = 0
            tdy = np.inf
            tmy = np.inf
        steps = abs(ex - cx0) + abs(ey - cy0)
        last = steps if not hit_mask[i] else steps - 1  # index of the last freed cell
        for k in range(last + 1):
            if 0 <= cy < rows and 0 <= cx < cols and mark[cy, cx] == _UNTOUCHED:
                mark[cy, cx] = _FREED
                _apply(logodds, cy, cx, l_free, l_min, l_max)
                n_upd += 1
            if k == steps:
                break
            if tmx < tmy:
                cx += sx
                tmx += tdx
            else:
                cy += sy
                tmy += tdy
    return n_upd


def _cells_on_segment(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """(K, 2) integer (col, row) of the cells the segment (map units) passes through, in order."""
    ts = [0.0, 1.0]
    for a0, a1 in ((x0, x1), (y0, y1)):
        if a1 != a0:
            lo, hi = sorted((a0, a1))
            lines = np.arange(np.floor(lo) + 1, np.ceil(hi))
            ts.extend(((lines - a0) / (a1 - a0)).tolist())
    ts = np.unique(np.clip(ts, 0.0, 1.0))
    mids = (ts[:-1] + ts[1:]) / 2 if len(ts) > 1 else np.array([0.0])
    pts = np.stack([x0 + mids * (x1 - x0), y0 + mids * (y1 - y0)], axis=1)
    cells = np.floor(pts).astype(np.int64)
    # the end cell (a ray may end exactly on a grid line)
    end = np.floor([x1, y1]).astype(np.int64)[None, :]
    start = np.floor([x0, y0]).astype(np.int64)[None, :]
    cells = np.vstack([start, cells, end])
    keep = np.ones(len(cells), bool)
    keep[1:] = np.any(cells[1:] != cells[:-1], axis=1)
    return cells[keep]


def insert_rays_ref(logodds, grid_meta, origin_xy, ends_xy, hit_mask, l_free, l_occ, l_min, l_max):
    """Reference of insert_rays_inplace: returns a new array, input unchanged."""
    out = np.array(logodds, dtype=np.float64, copy=True)
    ox, oy, res, rows, cols = grid_meta
    rows, cols = int(rows), int(cols)
    o = ((origin_xy[0] - ox) / res, (origin_xy[1] - oy) / res)
    hits, frees = set(), set()
    for (x, y), hit in zip(ends_xy, hit_mask):
        e = ((x - ox) / res, (y - oy) / res)
        cells = [tuple(cr) for cr in _cells_on_segment(o[0], o[1], e[0], e[1])]
        if hit:
            hits.add(cells[-1])
            cells = cells[:-1]
        frees.update(cells)
    base = np.nan_to_num(out, nan=0.0)
    for cells, l in ((hits, l_occ), (frees - hits, l_free)):
        for c, r in cells:
            if 0 <= r < rows and 0 <= c < cols:
                out[r, c] = np.clip(base[r, c] + l, l_min, l_max)
    return out
