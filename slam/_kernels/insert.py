"""Log-odds ray insertion into an occupancy grid (exact cell traversal, Amanatides & Woo 1987).

insert_rays_inplace: compiled; insert_rays_ref: an independent numpy statement of the same
update (cells found from the sorted crossings of each segment with the grid lines), for tests.

Update rule for one scan (as Hector's and Cartographer's "each cell once per scan", hits first):
every cell holding the end point of a hit ray gets `l_occ` once; every other cell crossed by
any ray (from the sensor origin to the end point; for a no-return ray the end cell too) gets
`l_free` once. A cell hit in this scan is not also freed by it, so walls seen at grazing
angles are not eroded by neighbouring beams. Values are clamped to [l_min, l_max]; NaN means
"never touched" and counts as 0 before the update. Cells outside the grid are skipped.

Optionally (free_margin) a hit ray frees cells only up to free_margin metres short of its end
point: the inverse sensor model of a range sensor with noise (Thrun, Burgard, Fox,
"Probabilistic Robotics", Sec. 9.2: cells within the measurement's uncertainty get no update).
The cells of that band that no other ray frees or hits are marked observed (a never-touched
cell becomes log-odds 0) and otherwise left unchanged. Without the band, beams that fall short
of a wall by the range noise clear the wall's front while those that fall long pile up behind
it, so the mapped wall sits behind the true one, by more the farther it was seen from.

grid_meta: (5,) [ox, oy, resolution, rows, cols]; logodds[row, col], row 0 at the bottom.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["insert_rays_inplace", "insert_rays_ref", "axis_walk"]

# marks in the per-call scratch grid
_UNTOUCHED, _FREED, _HIT, _OBSERVED = 0, 1, 2, 3


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
def insert_rays_inplace(logodds, grid_meta, origin_xy, ends_xy, hit_mask, l_free, l_occ, l_min, l_max,
                        free_margin=None):
    """Update `logodds` (rows, cols) in place with the rays origin_xy (2,) -> ends_xy (N, 2) (m).

    hit_mask: (N,) bool, True where the ray ended on an obstacle. free_margin: None or
    (N,) m >= 0; a hit ray frees only the cells up to the one holding the point free_margin
    short of its end, the rest up to the hit is marked observed (module docstring). Returns
    the number of cells whose value changed or that became observed.
    """
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols = int(grid_meta[3]), int(grid_meta[4])
    mark = np.zeros((rows, cols), dtype=np.uint8)
    path = np.empty((rows + cols + 4, 2), dtype=np.int64)
    n = ends_xy.shape[0]
    hit_at = np.full(n, -1, dtype=np.int64)   # path index of each ray's hit cell
    hit_rc = np.full((n, 2), -1, dtype=np.int64)
    x0 = (origin_xy[0] - ox) / res
    y0 = (origin_xy[1] - oy) / res
    # pass 1: the hit cells (read-only, so the order of rays does not matter)
    for i in range(n):
        if not hit_mask[i]:
            continue
        m = _traverse(x0, y0, (ends_xy[i, 0] - ox) / res, (ends_xy[i, 1] - oy) / res, path)
        k = m - 1
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
    # pass 2: free cells along every ray, up to its hit cell (no-return rays: to the end) or,
    # with a margin, up to the cell holding the point free_margin short of it
    banded = free_margin is not None
    # band cells, collected here and marked after every ray has freed its cells (pass 3); a
    # 4-connected walk over a length L crosses at most sqrt(2) L / res + 2 cells
    per_ray = 0
    if banded:
        for i in range(n):
            per_ray = max(per_ray, int(np.ceil(1.5 * free_margin[i] / res)) + 2)
    band = np.empty((n * per_ray, 2), dtype=np.int64)
    n_band = 0
    for i in range(n):
        ex, ey = (ends_xy[i, 0] - ox) / res, (ends_xy[i, 1] - oy) / res
        m = _traverse(x0, y0, ex, ey, path)
        last = hit_at[i] - 1 if hit_mask[i] else m - 1
        if banded and hit_mask[i] and free_margin[i] > 0.0:
            length = np.hypot(ex - x0, ey - y0) * res
            f = max(length - free_margin[i], 0.0) / length if length > 0.0 else 0.0
            # the walk is 4-connected, so the cell holding a point of the segment comes after
            # as many cells as its Manhattan distance from the start cell
            k_short = (abs(int(np.floor(x0 + f * (ex - x0))) - int(np.floor(x0)))
                       + abs(int(np.floor(y0 + f * (ey - y0))) - int(np.floor(y0))))
            if k_short < last:
                for k in range(k_short + 1, min(last + 1, k_short + 1 + per_ray)):
                    band[n_band, 0] = path[k, 0]
                    band[n_band, 1] = path[k, 1]
                    n_band += 1
                last = k_short
        for k in range(last + 1):
            cx, cy = path[k, 0], path[k, 1]
            if 0 <= cy < rows and 0 <= cx < cols and mark[cy, cx] == _UNTOUCHED:
                mark[cy, cx] = _FREED
                _apply(logodds, cy, cx, l_free, l_min, l_max)
                n_upd += 1
    # pass 3: the bands, after every ray has freed its cells, so the order of rays does not matter
    for b in range(n_band):
        cx, cy = band[b, 0], band[b, 1]
        if 0 <= cy < rows and 0 <= cx < cols and mark[cy, cx] == _UNTOUCHED:
            mark[cy, cx] = _OBSERVED
            if logodds[cy, cx] != logodds[cy, cx]:
                logodds[cy, cx] = 0.0
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
                    free_margin=None):
    """Reference of insert_rays_inplace: returns a new array, input unchanged."""
    out = np.array(logodds, dtype=np.float64, copy=True)
    ox, oy, res, rows, cols = grid_meta
    rows, cols = int(rows), int(cols)
    base = np.nan_to_num(out, nan=0.0)

    o = ((origin_xy[0] - ox) / res, (origin_xy[1] - oy) / res)
    margins = np.zeros(len(ends_xy)) if free_margin is None else np.asarray(free_margin, dtype=np.float64)
    hits, frees, observed = set(), set(), set()
    for (x, y), hit, margin in zip(ends_xy, hit_mask, margins):
        e = ((x - ox) / res, (y - oy) / res)
        cells = [tuple(cr) for cr in _cells_on_segment(o[0], o[1], e[0], e[1])]
        if hit:
            k = len(cells) - 1
            hits.add(cells[k])
            cells = cells[:k]
            if margin > 0:
                # the cells up to the one holding the point `margin` metres short of the end
                length = np.hypot(e[0] - o[0], e[1] - o[1]) * res
                f = max(length - margin, 0.0) / length if length > 0 else 0.0
                n_free = len(_cells_on_segment(o[0], o[1], o[0] + f * (e[0] - o[0]), o[1] + f * (e[1] - o[1])))
                observed.update(cells[n_free:])
                cells = cells[:n_free]
        frees.update(cells)
    for cells, l in ((hits, l_occ), (frees - hits, l_free)):
        for c, r in cells:
            if 0 <= r < rows and 0 <= c < cols:
                out[r, c] = np.clip(base[r, c] + l, l_min, l_max)
    for c, r in observed - hits - frees:
        if 0 <= r < rows and 0 <= c < cols and np.isnan(out[r, c]):
            out[r, c] = 0.0
    return out
