"""Log-odds ray insertion into an occupancy grid (exact cell traversal, Amanatides & Woo 1987).

insert_rays_inplace: compiled; insert_rays_ref: an independent numpy statement of the same
update (cells found from the sorted crossings of each segment with the grid lines), for tests.

Update rule for one scan (as Hector's and Cartographer's "each cell once per scan", hits first):
every cell holding the end point of a hit ray gets `l_occ` once; every other cell crossed by
any ray (from the sensor origin to the end point; for a no-return ray the end cell too) gets
`l_free` once. Optionally (snap_cells > 0) a hit moves back along its ray onto a cell of
higher log-odds just before it (see insert_rays_inplace). A cell hit in this scan is not also freed by it, so walls seen at grazing
angles are not eroded by neighbouring beams. Values are clamped to [l_min, l_max]; NaN means
"never touched" and counts as 0 before the update. Cells outside the grid are skipped.

grid_meta: (5,) [ox, oy, resolution, rows, cols]; logodds[row, col], row 0 at the bottom.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["insert_rays_inplace", "insert_rays_ref", "axis_walk"]

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
def axis_walk(p0, cell, d):
    """One axis of an Amanatides-Woo walk from coordinate p0 (cell units) in cell `cell`
    along the segment's extent d: (step -1/0/1, parameter per cell crossed, parameter at
    the first cell border)."""
    if d > 0:
        t_delta = 1.0 / d
        return 1, t_delta, (cell + 1 - p0) * t_delta
    if d < 0:
        t_delta = -1.0 / d
        return -1, t_delta, (p0 - cell) * t_delta
    return 0, np.inf, np.inf


@njit(cache=True)
def _traverse(x0, y0, x1, y1, path):
    """Cells (col, row) from the cell of (x0, y0) to the cell of (x1, y1), map units, into
    path (K, 2); returns their number (Amanatides-Woo, 4-connected)."""
    cx = int(np.floor(x0))
    cy = int(np.floor(y0))
    ex = int(np.floor(x1))
    ey = int(np.floor(y1))
    dx = x1 - x0
    dy = y1 - y0
    sx, tdx, tmx = axis_walk(x0, cx, dx)
    sy, tdy, tmy = axis_walk(y0, cy, dy)
    steps = abs(ex - cx) + abs(ey - cy)
    if steps + 1 > path.shape[0]:
        steps = path.shape[0] - 1  # cannot happen for rays inside the grid
    for k in range(steps + 1):
        path[k, 0] = cx
        path[k, 1] = cy
        if k == steps:
            break
        if tmx < tmy:
            cx += sx
            tmx += tdx
        else:
            cy += sy
            tmy += tdy
    return steps + 1


@njit(cache=True)
def _value(logodds, r, c, rows, cols):
    if r < 0 or r >= rows or c < 0 or c >= cols:
        return -np.inf
    v = logodds[r, c]
    return 0.0 if v != v else v


@njit(cache=True)
def insert_rays_inplace(logodds, grid_meta, origin_xy, ends_xy, hit_mask, l_free, l_occ, l_min, l_max,
                        snap_cells=0):
    """Update `logodds` (rows, cols) in place with the rays origin_xy (2,) -> ends_xy (N, 2) (m).

    hit_mask: (N,) bool, True where the ray ended on an obstacle. snap_cells: a hit is moved
    back along its ray, up to this many cells, while the cell before it holds higher log-odds
    (before this scan): range noise past a mapped surface then reinforces the surface instead
    of thickening the wall behind it; the cells between stay untouched. Returns the number of
    cells updated.
    """
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols = int(grid_meta[3]), int(grid_meta[4])
    mark = np.zeros((rows, cols), dtype=np.uint8)
    path = np.empty((rows + cols + 4, 2), dtype=np.int64)
    n = ends_xy.shape[0]
    hit_at = np.full(n, -1, dtype=np.int64)   # path index of each ray's (snapped) hit cell
    hit_rc = np.full((n, 2), -1, dtype=np.int64)
    x0 = (origin_xy[0] - ox) / res
    y0 = (origin_xy[1] - oy) / res
    # pass 1: where each hit ray's hit lands (read-only, so the order of rays does not matter)
    for i in range(n):
        if not hit_mask[i]:
            continue
        m = _traverse(x0, y0, (ends_xy[i, 0] - ox) / res, (ends_xy[i, 1] - oy) / res, path)
        k = m - 1
        for _ in range(snap_cells):
            if k == 0:
                break
            if (_value(logodds, path[k - 1, 1], path[k - 1, 0], rows, cols)
                    > _value(logodds, path[k, 1], path[k, 0], rows, cols)):
                k -= 1
            else:
                break
        hit_at[i] = k
        hit_rc[i, 0] = path[k, 1]
        hit_rc[i, 1] = path[k, 0]
    n_upd = 0
    for i in range(n):
        r, c = hit_rc[i, 0], hit_rc[i, 1]
        if hit_at[i] < 0 or r < 0 or r >= rows or c < 0 or c >= cols or mark[r, c] == _HIT:
            continue
        mark[r, c] = _HIT
        _apply(logodds, r, c, l_occ, l_min, l_max)
        n_upd += 1
    # pass 2: free cells along every ray, up to its hit cell (no-return rays: to the end)
    for i in range(n):
        m = _traverse(x0, y0, (ends_xy[i, 0] - ox) / res, (ends_xy[i, 1] - oy) / res, path)
        last = hit_at[i] - 1 if hit_mask[i] else m - 1
        for k in range(last + 1):
            cx, cy = path[k, 0], path[k, 1]
            if 0 <= cy < rows and 0 <= cx < cols and mark[cy, cx] == _UNTOUCHED:
                mark[cy, cx] = _FREED
                _apply(logodds, cy, cx, l_free, l_min, l_max)
                n_upd += 1
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


def insert_rays_ref(logodds, grid_meta, origin_xy, ends_xy, hit_mask, l_free, l_occ, l_min, l_max,
                    snap_cells=0):
    """Reference of insert_rays_inplace: returns a new array, input unchanged."""
    out = np.array(logodds, dtype=np.float64, copy=True)
    ox, oy, res, rows, cols = grid_meta
    rows, cols = int(rows), int(cols)
    base = np.nan_to_num(out, nan=0.0)

    def value(cell):
        c, r = cell
        return base[r, c] if 0 <= r < rows and 0 <= c < cols else -np.inf

    o = ((origin_xy[0] - ox) / res, (origin_xy[1] - oy) / res)
    hits, frees = set(), set()
    for (x, y), hit in zip(ends_xy, hit_mask):
        e = ((x - ox) / res, (y - oy) / res)
        cells = [tuple(cr) for cr in _cells_on_segment(o[0], o[1], e[0], e[1])]
        if hit:
            k = len(cells) - 1
            while k > 0 and len(cells) - 1 - k < snap_cells and value(cells[k - 1]) > value(cells[k]):
                k -= 1
            hits.add(cells[k])
            cells = cells[:k]
        frees.update(cells)
    for cells, l in ((hits, l_occ), (frees - hits, l_free)):
        for c, r in cells:
            if 0 <= r < rows and 0 <= c < cols:
                out[r, c] = np.clip(base[r, c] + l, l_min, l_max)
    return out
