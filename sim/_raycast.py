"""Lidar ray casting against wall segments: numba kernels and a plain numpy reference.

cast_rays: compiled, tests every segment for every ray (also runs as plain Python with
NUMBA_DISABLE_JIT=1); cast_rays_indexed: the same distances, but each ray tests only the
segments of the cells of a uniform grid (segment_grid) it crosses, walked in order from
its origin (Amanatides & Woo 1987) until a hit lies before the next cell;
cast_rays_ref: an independent vectorised numpy statement of the same thing, for tests.
Each ray has its own origin, so the beams of one revolution can be cast from the
lidar pose at each beam's own time (motion distortion).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["cast_rays", "cast_rays_indexed", "segment_grid", "cast_rays_ref"]

# a ray parallel to a segment (|cross| below this) cannot hit it at a single point
_PARALLEL_EPS = 1e-12
# m: a segment is filed in every cell its box, grown by this, touches, so a hit computed
# a rounding error outside a cell the ray walks through is still found there
_CELL_PAD = 1e-9


@njit(cache=True, nogil=True)
def cast_rays(segments, origins, angles, max_range):
    """Distance from each origin along its angle to the nearest segment.

    segments: (S, 4) x0, y0, x1, y1 (m); origins: (B, 2) m; angles: (B,) world frame, rad;
    max_range: m. Returns (B,) distances in m, inf where no segment lies within max_range.
    """
    n = origins.shape[0]
    out = np.empty(n)
    for b in range(n):
        ox = origins[b, 0]
        oy = origins[b, 1]
        dx = np.cos(angles[b])
        dy = np.sin(angles[b])
        best = np.inf
        for s in range(segments.shape[0]):
            t = _hit(segments, s, ox, oy, dx, dy)
            if t < best:
                best = t
        out[b] = best if best <= max_range else np.inf
    return out


@njit(cache=True, nogil=True, inline="always")
def _hit(segments, s, ox, oy, dx, dy):
    """Distance along the ray o + t d to segment s, inf if it misses."""
    ax = segments[s, 0]
    ay = segments[s, 1]
    ex = segments[s, 2] - ax
    ey = segments[s, 3] - ay
    denom = dx * ey - dy * ex
    if abs(denom) < _PARALLEL_EPS:
        return np.inf
    wx = ax - ox
    wy = ay - oy
    t = (wx * ey - wy * ex) / denom   # distance along the ray
    u = (wx * dy - wy * dx) / denom   # position along the segment, 0..1
    if t >= 0.0 and u >= 0.0 and u <= 1.0:
        return t
    return np.inf


def segment_grid(segments: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uniform grid over the segments' bounding box for cast_rays_indexed.

    segments: (S, 4) m; cell: cell size, m. Returns grid_meta (5,) [x0, y0, cell, cols, rows]
    (x0, y0 the lower-left corner, m), cell_start (rows * cols + 1,) and cell_segs (K,)
    int64: the segments of cell (row, col) are cell_segs[cell_start[k]:cell_start[k + 1]],
    k = row * cols + col. A segment is filed in the cells of the boxes of its pieces at most
    cell / 2 long (grown by a nanometre): every cell it passes through, and a few beside it.
    """
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    if not cell > 0:
        raise ValueError(f"cell must be > 0, got {cell}")
    if len(seg) == 0:
        return (np.array([0.0, 0.0, cell, 1.0, 1.0]), np.zeros(2, dtype=np.int64),
                np.zeros(0, dtype=np.int64))
    x0 = min(seg[:, 0].min(), seg[:, 2].min()) - cell
    y0 = min(seg[:, 1].min(), seg[:, 3].min()) - cell
    cols = int(math.ceil((max(seg[:, 0].max(), seg[:, 2].max()) + cell - x0) / cell))
    rows = int(math.ceil((max(seg[:, 1].max(), seg[:, 3].max()) + cell - y0) / cell))
    seg_ids, cell_ids = [], []
    for s, (ax, ay, bx, by) in enumerate(seg):
        n = max(1, int(math.ceil(2.0 * math.hypot(bx - ax, by - ay) / cell)))
        f = np.arange(n + 1) / n
        px, py = ax + f * (bx - ax), ay + f * (by - ay)
        lo_x, hi_x = np.minimum(px[:-1], px[1:]) - _CELL_PAD, np.maximum(px[:-1], px[1:]) + _CELL_PAD
        lo_y, hi_y = np.minimum(py[:-1], py[1:]) - _CELL_PAD, np.maximum(py[:-1], py[1:]) + _CELL_PAD
        c0 = np.floor((lo_x - x0) / cell).astype(np.int64)
        c1 = np.floor((hi_x - x0) / cell).astype(np.int64)
        r0 = np.floor((lo_y - y0) / cell).astype(np.int64)
        r1 = np.floor((hi_y - y0) / cell).astype(np.int64)
        cells = set()
        for a, b, c, d in zip(r0, r1, c0, c1):   # each piece spans at most 2 x 2 cells
            for r in range(a, b + 1):
                for c_ in range(c, d + 1):
                    cells.add(r * cols + c_)
        cells = sorted(cells)
        seg_ids.extend([s] * len(cells))
        cell_ids.extend(cells)
    seg_ids = np.asarray(seg_ids, dtype=np.int64)
    cell_ids = np.asarray(cell_ids, dtype=np.int64)
    order = np.lexsort((seg_ids, cell_ids))
    cell_start = np.zeros(rows * cols + 1, dtype=np.int64)
    np.cumsum(np.bincount(cell_ids, minlength=rows * cols), out=cell_start[1:])
    return np.array([x0, y0, cell, cols, rows]), cell_start, seg_ids[order]


@njit(cache=True, inline="always")
def _slab(t_in, t_out, o, d, lo, hi):
    """The ray parameter interval [t_in, t_out] cut to lo <= o + t d <= hi on one axis
    (t_out = -1 when the ray runs outside the slab)."""
    if d != 0.0:
        ta = (lo - o) / d
        tb = (hi - o) / d
        return max(t_in, min(ta, tb)), min(t_out, max(ta, tb))
    if o < lo or o > hi:
        return t_in, -1.0
    return t_in, t_out


@njit(cache=True, inline="always")
def _cell_exit(o, d, lo, i, h):
    """The ray parameter where it leaves cell i (of size h from lo) on one axis; inf when it
    does not move along that axis."""
    if d == 0.0:
        return np.inf
    return (lo + (i + (1 if d > 0.0 else 0)) * h - o) / d


@njit(cache=True, nogil=True)
def cast_rays_indexed(segments, grid_meta, cell_start, cell_segs, origins, angles, max_range):
    """cast_rays (same result, bit for bit) through the grid of segment_grid.

    segments: (S, 4) m; grid_meta, cell_start, cell_segs: segment_grid(segments, cell);
    origins: (B, 2) m; angles: (B,) world frame, rad; max_range: m (may be inf).
    Returns (B,) distances in m, inf where no segment lies within max_range.
    """
    x0 = grid_meta[0]
    y0 = grid_meta[1]
    h = grid_meta[2]
    cols = int(grid_meta[3])
    rows = int(grid_meta[4])
    x1 = x0 + cols * h
    y1 = y0 + rows * h
    n = origins.shape[0]
    out = np.empty(n)
    seen = np.full(segments.shape[0], -1, dtype=np.int64)   # last ray that tested a segment
    for b in range(n):
        ox = origins[b, 0]
        oy = origins[b, 1]
        dx = np.cos(angles[b])
        dy = np.sin(angles[b])
        best = np.inf
        # the part of the ray inside the grid's box: [t_in, t_out]
        t_in, t_out = _slab(0.0, max_range, ox, dx, x0, x1)
        t_in, t_out = _slab(t_in, t_out, oy, dy, y0, y1)
        if t_in <= t_out:
            c = min(max(int(math.floor((ox + t_in * dx - x0) / h)), 0), cols - 1)
            r = min(max(int(math.floor((oy + t_in * dy - y0) / h)), 0), rows - 1)
            step_c = 1 if dx > 0.0 else -1
            step_r = 1 if dy > 0.0 else -1
            while True:
                k = r * cols + c
                for j in range(cell_start[k], cell_start[k + 1]):
                    s = cell_segs[j]
                    if seen[s] != b:
                        seen[s] = b
                        t = _hit(segments, s, ox, oy, dx, dy)
                        if t < best:
                            best = t
                # where the ray leaves this cell
                tc = _cell_exit(ox, dx, x0, c, h)
                tr = _cell_exit(oy, dy, y0, r, h)
                t_next = min(tc, tr)
                if best <= t_next or t_next > t_out:
                    break
                if tc < tr:
                    c += step_c
                    if c < 0 or c >= cols:
                        break
                else:
                    r += step_r
                    if r < 0 or r >= rows:
                        break
        out[b] = best if best <= max_range else np.inf
    return out


def cast_rays_ref(segments: np.ndarray, origins: np.ndarray, angles: np.ndarray,
                  max_range: float) -> np.ndarray:
    """Reference for cast_rays (same arguments and result): a dense (B, S) numpy solve of
    origin + t * d = a + u * e by Cramer's rule over every ray-segment pair."""
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    org = np.asarray(origins, dtype=np.float64).reshape(-1, 2)
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)          # (B, 2)
    a = seg[:, :2]
    e = seg[:, 2:] - a                                              # (S, 2)
    w = a[None, :, :] - org[:, None, :]                             # (B, S, 2)
    # 2x2 system [d, -e] [t, u]^T = w
    det = -d[:, None, 0] * e[None, :, 1] + d[:, None, 1] * e[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (-w[..., 0] * e[None, :, 1] + w[..., 1] * e[None, :, 0]) / det
        u = (d[:, None, 0] * w[..., 1] - d[:, None, 1] * w[..., 0]) / det
    ok = (np.abs(det) >= _PARALLEL_EPS) & (t >= 0) & (u >= 0) & (u <= 1)
    dist = np.where(ok, t, np.inf).min(axis=1) if seg.shape[0] else np.full(len(org), np.inf)
    return np.where(dist <= max_range, dist, np.inf)
