"""The output map's surface kernels: lidar hits moved onto the wall surface they came from,
and free space carved by the rays that stop short of them.

All coordinates are in cell units of the output grid (x = (x_m - ox) / res, cell (row, col)
= (floor(y), floor(x))). A hit carries a weight w = 1 / sigma^2 from the sensor's noise model.

- `hit_sigmas`: sigma of every hit from the noise model at the mean range of its neighbouring
  hits in the same scan (a beam's own range would favour the readings that came out short).
- `project_hits`: one mean-shift pass. The weighted moments (w, wx, wy, wxx, wxy, wyy) of the
  `density` points are summed per (side sector, cell) and then over a square window of
  (2 radius + 1)^2 cells. A hit is projected onto the line fitted (weighted mean and principal
  axis) to the density points of its own side within the window of the cell it is in, until
  the projection stays in its cell: the hit moves along the local normal onto the surface.
  Sides: a hit's normal, oriented towards the sensor, falls in one of `SECTORS` direction
  sectors; a hit reads the hits of its own sector +- `spread` (the output map's wide pass: the
  two adjacent ones too, normals within 22.5-45 degrees; its fine pass: its own), so the two
  faces of a thin wall (opposite normals) are never averaged into one, nor, away from the
  vertex, the two walls of a corner.
- `hit_normals`: the oriented normal sector of every hit, from its neighbouring beams.
- `carve_free`: per scan, every cell a ray crosses before the point `margin` short of its
  hit counts one free observation (once per scan; the cells holding the scan's hits are not
  freed by it).
- `mark_surface`: the cells holding enough moved hits, each at least a share of the best cell
  of its 3 x 3 neighbourhood (walls one cell thick).

Every kernel has a plain-numpy reference (`*_ref`) the tests compare it with.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from slam._kernels.insert import _traverse

__all__ = ["SECTORS", "hit_sigmas", "hit_sigmas_ref", "hit_normals", "hit_normals_ref",
           "project_hits", "project_hits_ref", "carve_free", "carve_free_ref", "mark_surface",
           "mark_surface_ref", "line_fit_ref"]

SECTORS = 16
_MOMENTS = 6
_DEGENERATE = 1e-9   # cells^2: a window's spread below this has no direction


@njit(cache=True, nogil=True)
def _sigma(r, noise):
    """Range sigma at r of the model `noise` (slam.range_noise.RangeNoise.as_array)."""
    k = int(noise[3])
    b = 4 + 3 * (k - 1)                # the last band, also past every band
    for j in range(k - 1):
        if r < noise[4 + 3 * j]:
            b = 4 + 3 * j
            break
    acc = noise[b + 1] + noise[b + 2] * r
    s = math.sqrt(noise[0] * noise[0] + (acc / noise[1]) * (acc / noise[1]))
    return s if s > noise[2] else noise[2]


@njit(cache=True, nogil=True)
def hit_sigmas(ranges, starts, neighbours, jump, noise):
    """(N,) range sigma (m) of every hit. ranges: (N,) m, hits of all scans in beam order;
    starts: (S + 1,) index of each scan's first hit; neighbours: hits on each side whose mean
    range the noise model is read at (those within `jump` of the hit's range, as a fraction);
    noise: the model as RangeNoise.as_array gives it."""
    n = ranges.shape[0]
    out = np.empty(n)
    for s in range(starts.shape[0] - 1):
        lo, hi = starts[s], starts[s + 1]
        for i in range(lo, hi):
            r = ranges[i]
            total, count = 0.0, 0
            for j in range(max(lo, i - neighbours), min(hi, i + neighbours + 1)):
                if j != i and abs(ranges[j] - r) <= jump * r:
                    total += ranges[j]
                    count += 1
            rbar = total / count if count else r
            out[i] = _sigma(rbar, noise)
    return out


@njit(cache=True, nogil=True)
def _window_moments(px, py, w, sector, rows, cols, nsec, radius):
    """The weighted moments of the points per (sector, cell), summed over the (2 radius + 1)^2
    window around each cell: (index (rows, cols) int64, sums (K, nsec, 6)). Only the K cells
    whose window holds a point get a row (index -1 elsewhere), so the memory grows with the
    walls' length, not with the map's area."""
    index = np.full((rows, cols), -1, dtype=np.int64)
    cell = np.empty(px.shape[0], dtype=np.int64)
    for i in range(px.shape[0]):
        r = int(math.floor(py[i]))
        c = int(math.floor(px[i]))
        cell[i] = r * cols + c if 0 <= r < rows and 0 <= c < cols else -1
        if cell[i] >= 0:
            for rr in range(max(0, r - radius), min(rows, r + radius + 1)):
                for cc in range(max(0, c - radius), min(cols, c + radius + 1)):
                    index[rr, cc] = 0          # active (numbered below)
    k = 0
    for r in range(rows):
        for c in range(cols):
            if index[r, c] == 0:
                index[r, c] = k
                k += 1
            else:
                index[r, c] = -1
    m = np.zeros((k, nsec, _MOMENTS))
    for i in range(px.shape[0]):
        if cell[i] < 0:
            continue
        j = index[cell[i] // cols, cell[i] % cols]
        s = sector[i]
        x, y, wi = px[i], py[i], w[i]
        m[j, s, 0] += wi
        m[j, s, 1] += wi * x
        m[j, s, 2] += wi * y
        m[j, s, 3] += wi * x * x
        m[j, s, 4] += wi * x * y
        m[j, s, 5] += wi * y * y
    # separable window sum over the active cells (an inactive cell's partial sums are zero)
    tmp = np.zeros_like(m)
    out = np.zeros_like(m)
    for axis in range(2):
        src = m if axis == 0 else tmp
        dst = tmp if axis == 0 else out
        for r in range(rows):
            for c in range(cols):
                j = index[r, c]
                if j < 0:
                    continue
                for d in range(-radius, radius + 1):
                    rr, cc = (r + d, c) if axis == 0 else (r, c + d)
                    if rr < 0 or rr >= rows or cc < 0 or cc >= cols or index[rr, cc] < 0:
                        continue
                    q = index[rr, cc]
                    for s in range(nsec):
                        for t in range(_MOMENTS):
                            dst[j, s, t] += src[q, s, t]
    return index, out


@njit(cache=True, nogil=True)
def _fit(sums, j, s0, spread, out):
    """Line fit to the window moments of sectors s0 - spread .. s0 + spread of active cell j:
    out = (weight, mean x, mean y, normal x, normal y); False if the window is empty or its
    points all lie at one place."""
    nsec = sums.shape[1]
    w = sx = sy = sxx = sxy = syy = 0.0
    for d in range(-spread, spread + 1):
        s = (s0 + d) % nsec
        w += sums[j, s, 0]
        sx += sums[j, s, 1]
        sy += sums[j, s, 2]
        sxx += sums[j, s, 3]
        sxy += sums[j, s, 4]
        syy += sums[j, s, 5]
    if w <= 0.0:
        return False
    mx, my = sx / w, sy / w
    a = sxx / w - mx * mx
    b = sxy / w - mx * my
    d_ = syy / w - my * my
    if a + d_ <= _DEGENERATE:   # one point (or all at one place): no direction
        return False
    theta = 0.5 * math.atan2(2.0 * b, a - d_)   # direction of the principal (surface) axis
    out[0] = w
    out[1] = mx
    out[2] = my
    out[3] = -math.sin(theta)
    out[4] = math.cos(theta)
    return True


@njit(cache=True, nogil=True)
def _sector_of(nx, ny, nsec):
    a = math.atan2(ny, nx) + math.pi
    s = int(a / (2.0 * math.pi) * nsec)
    return s % nsec


@njit(cache=True, nogil=True)
def _line_through(px, py, w, i, lo, hi, gate, out):
    """Weighted line through the hits lo..hi-1 within `gate` of hit i: out = its unit normal;
    False with fewer than 3 such hits."""
    sw = sx = sy = sxx = sxy = syy = 0.0
    k = 0
    for j in range(lo, hi):
        dx, dy = px[j] - px[i], py[j] - py[i]
        if dx * dx + dy * dy <= gate * gate:
            sw += w[j]
            sx += w[j] * dx
            sy += w[j] * dy
            sxx += w[j] * dx * dx
            sxy += w[j] * dx * dy
            syy += w[j] * dy * dy
            k += 1
    if k < 3:
        return False
    mx, my = sx / sw, sy / sw
    a, b, d = sxx / sw - mx * mx, sxy / sw - mx * my, syy / sw - my * my
    theta = 0.5 * math.atan2(2.0 * b, a - d)
    out[0] = -math.sin(theta)
    out[1] = math.cos(theta)
    return True


@njit(cache=True, nogil=True)
def hit_normals(px, py, w, starts, neighbours, gate, ox, oy):
    """(N,) sector of each hit's normal, oriented towards its ray's origin (ox, oy) (N,): the
    weighted line through the hit and its `neighbours` beams on each side in the same scan
    that lie within `gate` cells of it (the direction to the sensor when fewer than 3 do).
    starts: (S + 1,) each scan's first hit."""
    n = px.shape[0]
    out = np.zeros(n, dtype=np.int64)
    fit = np.empty(2)
    for s in range(starts.shape[0] - 1):
        lo, hi = starts[s], starts[s + 1]
        for i in range(lo, hi):
            nx, ny = ox[i] - px[i], oy[i] - py[i]
            if _line_through(px, py, w, i, max(lo, i - neighbours), min(hi, i + neighbours + 1),
                             gate, fit):
                if fit[0] * nx + fit[1] * ny < 0.0:
                    nx, ny = -fit[0], -fit[1]
                else:
                    nx, ny = fit[0], fit[1]
            out[i] = _sector_of(nx, ny, SECTORS)
    return out


@njit(cache=True, nogil=True)
def project_hits(px, py, dx, dy, w, sector, spread, rows, cols, radius, iterations):
    """(N, 2) the points (px, py) each projected onto the line fitted to the density points
    (dx, dy) with weights w of its own side (sector +- spread) in the window of its cell, repeated
    until the projection stays in its cell (at most `iterations` times)."""
    index, sums = _window_moments(dx, dy, w, sector, rows, cols, SECTORS, radius)
    n = px.shape[0]
    out = np.empty((n, 2))
    fit = np.empty(5)
    for i in range(n):
        x, y = px[i], py[i]
        for _ in range(iterations):
            r = int(math.floor(y))
            c = int(math.floor(x))
            if r < 0 or r >= rows or c < 0 or c >= cols or index[r, c] < 0:
                break
            if not _fit(sums, index[r, c], sector[i], spread, fit):
                break
            d = (x - fit[1]) * fit[3] + (y - fit[2]) * fit[4]
            x -= d * fit[3]
            y -= d * fit[4]
            if int(math.floor(y)) == r and int(math.floor(x)) == c:
                break
        out[i, 0] = x
        out[i, 1] = y
    return out


@njit(cache=True, nogil=True)
def carve_free(origins, starts, ex, ey, margin, rows, cols):
    """(rows, cols) int32: per cell, the number of scans whose rays crossed it before the
    point `margin` (N,) cells short of their end (ex, ey) (N,); origins: (S, 2) each scan's
    ray origin; starts: (S + 1,) each scan's first ray. A scan's end cells are not freed by it.
    Also returns (rows, cols) bool: cells some ray reached (observed)."""
    free = np.zeros((rows, cols), dtype=np.int32)
    seen = np.zeros((rows, cols), dtype=np.bool_)
    stamp = np.full((rows, cols), -1, dtype=np.int64)     # scan that freed or ended in it
    path = np.empty((rows + cols + 4, 2), dtype=np.int64)
    for s in range(starts.shape[0] - 1):
        x0, y0 = origins[s, 0], origins[s, 1]
        for i in range(starts[s], starts[s + 1]):
            r = int(math.floor(ey[i]))
            c = int(math.floor(ex[i]))
            if 0 <= r < rows and 0 <= c < cols:
                stamp[r, c] = s
                seen[r, c] = True
        for i in range(starts[s], starts[s + 1]):
            lx, ly = ex[i] - x0, ey[i] - y0
            length = math.sqrt(lx * lx + ly * ly)
            f = max(length - margin[i], 0.0) / length if length > 0.0 else 0.0
            m = _traverse(x0, y0, x0 + f * lx, y0 + f * ly, path)
            for k in range(m):
                c, r = path[k, 0], path[k, 1]
                if 0 <= r < rows and 0 <= c < cols:
                    seen[r, c] = True
                    if stamp[r, c] != s:
                        stamp[r, c] = s
                        free[r, c] += 1
    return free, seen


@njit(cache=True, nogil=True)
def mark_surface(px, py, w, rows, cols, min_hits, share):
    """(rows, cols) bool: cells holding at least min_hits of the points (px, py) whose weight
    sum is at least `share` of the largest in their 3 x 3 neighbourhood; and (rows, cols) the
    weight sums."""
    total = np.zeros((rows, cols))
    count = np.zeros((rows, cols), dtype=np.int64)
    for i in range(px.shape[0]):
        r = int(math.floor(py[i]))
        c = int(math.floor(px[i]))
        if 0 <= r < rows and 0 <= c < cols:
            total[r, c] += w[i]
            count[r, c] += 1
    out = np.zeros((rows, cols), dtype=np.bool_)
    for r in range(rows):
        for c in range(cols):
            if count[r, c] < min_hits:
                continue
            best = 0.0
            for rr in range(max(0, r - 1), min(rows, r + 2)):
                for cc in range(max(0, c - 1), min(cols, c + 2)):
                    best = max(best, total[rr, cc])
            out[r, c] = total[r, c] >= share * best
    return out, total


# --- plain-numpy references ---------------------------------------------------------------

def hit_sigmas_ref(ranges, starts, neighbours, jump, noise):
    """Reference of hit_sigmas."""
    stddev, nsig, floor, k = noise[:4]
    bands = np.asarray(noise[4:4 + 3 * int(k)]).reshape(-1, 3)
    out = np.empty(len(ranges))
    for lo, hi in zip(starts[:-1], starts[1:]):
        for i in range(lo, hi):
            idx = np.arange(max(lo, i - neighbours), min(hi, i + neighbours + 1))
            idx = idx[(idx != i) & (np.abs(ranges[idx] - ranges[i]) <= jump * ranges[i])]
            rbar = ranges[idx].mean() if len(idx) else ranges[i]
            below = np.flatnonzero(rbar < bands[:-1, 0])
            up_to, a, ratio = bands[below[0] if len(below) else -1]
            out[i] = max(np.hypot(stddev, (a + ratio * rbar) / nsig), floor)
    return out


def line_fit_ref(x, y, w):
    """(mean (2,), unit normal (2,)) of the weighted least-squares line through the points."""
    mean = np.array([np.average(x, weights=w), np.average(y, weights=w)])
    d = np.stack([x - mean[0], y - mean[1]])
    cov = (d * w) @ d.T / w.sum()
    vals, vecs = np.linalg.eigh(cov)
    return mean, vecs[:, 0]


def _window(px, py, r, c, radius):
    return ((np.floor(py) >= r - radius) & (np.floor(py) <= r + radius)
            & (np.floor(px) >= c - radius) & (np.floor(px) <= c + radius))


def _inside(x, y, rows, cols):
    return 0 <= np.floor(y) < rows and 0 <= np.floor(x) < cols


def hit_normals_ref(px, py, w, starts, neighbours, gate, ox, oy):
    """Reference of hit_normals."""
    out = np.zeros(len(px), dtype=np.int64)
    for lo, hi in zip(starts[:-1], starts[1:]):
        for i in range(lo, hi):
            n = np.array([ox[i] - px[i], oy[i] - py[i]])
            idx = np.arange(max(lo, i - neighbours), min(hi, i + neighbours + 1))
            idx = idx[np.hypot(px[idx] - px[i], py[idx] - py[i]) <= gate]
            if len(idx) >= 3:
                _, normal = line_fit_ref(px[idx], py[idx], w[idx])
                n = normal if normal @ n >= 0 else -normal
            out[i] = int((np.arctan2(n[1], n[0]) + np.pi) / (2 * np.pi) * SECTORS) % SECTORS
    return out


def project_hits_ref(px, py, dx, dy, w, sector, spread, rows, cols, radius, iterations):
    """Reference of project_hits."""
    keep = (np.floor(dy) >= 0) & (np.floor(dy) < rows) & (np.floor(dx) >= 0) & (np.floor(dx) < cols)
    out = np.empty((len(px), 2))
    for i in range(len(px)):
        p = np.array([px[i], py[i]], dtype=np.float64)
        near_sector = ((sector - sector[i] + spread) % SECTORS) <= 2 * spread
        for _ in range(iterations):
            if not _inside(p[0], p[1], rows, cols):
                break
            cell = np.floor(p)
            sel = keep & near_sector & _window(dx, dy, cell[1], cell[0], radius)
            if w[sel].sum() <= 0:
                break
            mean, normal = line_fit_ref(dx[sel], dy[sel], w[sel])
            var = np.average((dx[sel] - mean[0]) ** 2 + (dy[sel] - mean[1]) ** 2, weights=w[sel])
            if var <= _DEGENERATE:
                break
            p = p - ((p - mean) @ normal) * normal
            if np.array_equal(np.floor(p), cell):
                break
        out[i] = p
    return out


def carve_free_ref(origins, starts, ex, ey, margin, rows, cols):
    """Reference of carve_free (cells of each ray from slam._kernels.insert's reference walk)."""
    from slam._kernels.insert import _cells_on_segment
    free = np.zeros((rows, cols), dtype=np.int32)
    seen = np.zeros((rows, cols), dtype=bool)
    for s, (lo, hi) in enumerate(zip(starts[:-1], starts[1:])):
        x0, y0 = origins[s]
        ends = {(int(np.floor(ey[i])), int(np.floor(ex[i]))) for i in range(lo, hi)}
        crossed = set()
        for i in range(lo, hi):
            length = np.hypot(ex[i] - x0, ey[i] - y0)
            f = max(length - margin[i], 0.0) / length if length > 0 else 0.0
            cells = _cells_on_segment(x0, y0, x0 + f * (ex[i] - x0), y0 + f * (ey[i] - y0))
            crossed.update((int(r), int(c)) for c, r in cells)
        for r, c in ends | crossed:
            if 0 <= r < rows and 0 <= c < cols:
                seen[r, c] = True
        for r, c in crossed - ends:
            if 0 <= r < rows and 0 <= c < cols:
                free[r, c] += 1
    return free, seen


def mark_surface_ref(px, py, w, rows, cols, min_hits, share):
    """Reference of mark_surface."""
    r = np.floor(py).astype(np.int64)
    c = np.floor(px).astype(np.int64)
    ok = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    total = np.zeros((rows, cols))
    count = np.zeros((rows, cols), dtype=np.int64)
    np.add.at(total, (r[ok], c[ok]), w[ok])
    np.add.at(count, (r[ok], c[ok]), 1)
    padded = np.pad(total, 1)
    best = np.max([padded[1 + a:1 + a + rows, 1 + b:1 + b + cols]
                   for a in (-1, 0, 1) for b in (-1, 0, 1)], axis=0)
    return (count >= min_hits) & (total >= share * best), total
