"""Truncated signed distance (TSDF) insertion, compiled (Cartographer's TSDFRangeDataInserter2D
and its 2D normal estimation).

estimate_normals: per hit (hits in bearing order), the angle of the surface normal facing the
sensor: the mean of the unit normals of the segments to its neighbouring hits, up to
num_samples // 2 on each side and only while they lie closer than `radius`.

tsdf_insert: for each hit, every cell the ray crosses from `truncation` before the hit to
`truncation` beyond it (exact traversal) takes the hit's signed distance: the cell centre's
offset from the hit along the normal, positive in
front of the surface, clamped to +-truncation. It is averaged into the cell with the weight
  kernel(angle between normal and the ray back to the sensor, angle_bandwidth)
  * kernel(signed distance, distance_bandwidth)
(Gaussian densities; a bandwidth of 0 switches the factor off); the stored weight saturates at
max_weight, so old observations fade. A cell is updated once per scan, by the first hit (in
bearing order) whose ray reaches it: `stamp` holds the scan id that last updated each cell.

cells_under: the cells under points (the lookups of the matchers' weights and checks).

*_ref: plain numpy/python statements of the same for the tests.
grid meta: (5,) [ox, oy, resolution, rows, cols]; arrays [row, col], row 0 at the bottom.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from slam._kernels.insert import _cells_on_segment, _traverse

__all__ = ["estimate_normals", "tsdf_insert", "cells_under", "estimate_normals_ref", "tsdf_insert_ref",
           "cells_under_ref"]

_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


@njit(cache=True, nogil=True)
def _kernel(x, bandwidth):
    if bandwidth <= 0.0:
        return 1.0
    z = x / bandwidth
    return _INV_SQRT_2PI / bandwidth * math.exp(-0.5 * z * z)


@njit(cache=True, nogil=True)
def _wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


@njit(cache=True, nogil=True)
def estimate_normals(origin, hits, num_samples, radius):
    """(N,) normal angles (rad) of hits (N, 2) sorted by bearing from origin (2,)."""
    n = hits.shape[0]
    out = np.empty(n)
    half = num_samples // 2
    # dist[j, t - 1] = |hits[j + t] - hits[j]|: the distance of each pair of a sample window,
    # computed once for the window tests and the normals of both its points
    dist = np.empty((n, max(half, 1)))
    for j in range(n):
        for t in range(1, min(half, n - 1 - j) + 1):
            dist[j, t - 1] = math.hypot(hits[j + t, 0] - hits[j, 0], hits[j + t, 1] - hits[j, 1])
    for j in range(n):
        ex, ey = hits[j, 0], hits[j, 1]
        tox, toy = origin[0] - ex, origin[1] - ey
        mx, my = 0.0, 0.0
        lo = j
        while lo > 0 and j - lo < half and dist[lo - 1, j - lo] < radius:
            lo -= 1
        hi = j
        while hi < n - 1 and hi - j < half and dist[j, hi - j] < radius:
            hi += 1
        for q in range(lo, hi + 1):
            if q == j:
                continue
            d = dist[q, j - q - 1] if q < j else dist[j, q - j - 1]
            if d < 1e-9:
                continue
            tx, ty = ex - hits[q, 0], ey - hits[q, 1]
            nx, ny = -ty / d, tx / d
            if nx * tox + ny * toy < 0.0:
                nx, ny = -nx, -ny
            mx += nx
            my += ny
        if mx == 0.0 and my == 0.0:
            mx, my = tox, toy
        out[j] = math.atan2(my, mx)
    return out


@njit(cache=True, nogil=True)
def tsdf_insert(tsd, weight, stamp, match, scan_id, meta, origin, hits, normals, truncation, max_weight,
                angle_bandwidth, distance_bandwidth):
    """Insert one scan's hits (N, 2) (bearing order) with their normals (N,) from origin (2,).
    tsd, weight (rows, cols) float64 and stamp (rows, cols) int64 are updated in place, and
    match (rows, cols) float64, which holds 1 - tsd / truncation, kept so in every cell
    whose tsd changes. Returns the number of cell updates."""
    ox, oy, res = meta[0], meta[1], meta[2]
    rows, cols = int(meta[3]), int(meta[4])
    path = np.empty((int(4.0 * truncation / res) + 8, 2), np.int64)
    n_upd = 0
    for h in range(hits.shape[0]):
        hx, hy = hits[h, 0], hits[h, 1]
        rx, ry = hx - origin[0], hy - origin[1]
        rng = math.hypot(rx, ry)
        if rng < truncation:
            continue
        ux, uy = rx / rng, ry / rng
        nx, ny = math.cos(normals[h]), math.sin(normals[h])
        w_angle = _kernel(_wrap(normals[h] - math.atan2(-uy, -ux)), angle_bandwidth)
        k = _traverse((hx - truncation * ux - ox) / res, (hy - truncation * uy - oy) / res,
                      (hx + truncation * ux - ox) / res, (hy + truncation * uy - oy) / res, path)
        for q in range(k):
            c, r = path[q, 0], path[q, 1]
            if c < 0 or r < 0 or c >= cols or r >= rows or stamp[r, c] == scan_id:
                continue
            stamp[r, c] = scan_id
            cx = ox + (c + 0.5) * res
            cy = oy + (r + 0.5) * res
            d = (cx - hx) * nx + (cy - hy) * ny
            d = min(max(d, -truncation), truncation)
            w = w_angle * _kernel(d, distance_bandwidth)
            if w <= 0.0:
                continue
            w0 = weight[r, c]
            total = w0 + w
            tsd[r, c] = (tsd[r, c] * w0 + d * w) / total
            match[r, c] = 1.0 - tsd[r, c] / truncation
            weight[r, c] = min(total, max_weight)
            n_upd += 1
    return n_upd


@njit(cache=True, nogil=True)
def cells_under(meta, xy):
    """(row, col, inside) of the cells of the grid with meta (5,) under the points xy (N, 2) m;
    row and col 0 outside the grid."""
    ox, oy, res = meta[0], meta[1], meta[2]
    rows, cols = int(meta[3]), int(meta[4])
    n = xy.shape[0]
    r = np.zeros(n, np.int64)
    c = np.zeros(n, np.int64)
    inside = np.zeros(n, np.bool_)
    for k in range(n):
        ck = np.int64(np.floor((xy[k, 0] - ox) / res))
        rk = np.int64(np.floor((xy[k, 1] - oy) / res))
        if 0 <= rk < rows and 0 <= ck < cols:
            r[k] = rk
            c[k] = ck
            inside[k] = True
    return r, c, inside


def cells_under_ref(meta, xy):
    """Reference of cells_under, vectorised."""
    c = np.floor((xy[:, 0] - meta[0]) / meta[2]).astype(np.int64)
    r = np.floor((xy[:, 1] - meta[1]) / meta[2]).astype(np.int64)
    inside = (r >= 0) & (r < meta[3]) & (c >= 0) & (c < meta[4])
    return np.where(inside, r, 0), np.where(inside, c, 0), inside


def estimate_normals_ref(origin, hits, num_samples, radius):
    """Reference of estimate_normals."""
    origin = np.asarray(origin, float)
    hits = np.asarray(hits, float)
    out = np.empty(len(hits))
    half = num_samples // 2
    for j, e in enumerate(hits):
        near = np.hypot(*(hits - e).T) < radius
        lo = j
        while lo > 0 and j - lo < half and near[lo - 1]:
            lo -= 1
        hi = j
        while hi < len(hits) - 1 and hi - j < half and near[hi + 1]:
            hi += 1
        to_origin = origin - e
        total = np.zeros(2)
        for q in range(lo, hi + 1):
            t = e - hits[q]
            if q == j or np.hypot(*t) < 1e-9:
                continue
            normal = np.array([-t[1], t[0]]) / np.hypot(*t)
            total += normal if normal @ to_origin >= 0 else -normal
        if not total.any():
            total = to_origin
        out[j] = np.arctan2(total[1], total[0])
    return out


def tsdf_insert_ref(tsd, weight, stamp, match, scan_id, meta, origin, hits, normals, truncation, max_weight,
                    angle_bandwidth, distance_bandwidth):
    """Reference of tsdf_insert (cells of each ray from the sorted grid-line crossings)."""
    def kernel(x, bw):
        return 1.0 if bw <= 0 else np.exp(-0.5 * (x / bw) ** 2) / (np.sqrt(2 * np.pi) * bw)

    ox, oy, res, rows, cols = meta
    origin = np.asarray(origin, float)
    n_upd = 0
    for hit, normal in zip(np.asarray(hits, float), normals):
        ray = hit - origin
        rng = np.hypot(*ray)
        if rng < truncation:
            continue
        u = ray / rng
        nvec = np.array([np.cos(normal), np.sin(normal)])
        back = np.arctan2(-u[1], -u[0])
        w_angle = kernel(np.arctan2(np.sin(normal - back), np.cos(normal - back)), angle_bandwidth)
        a = (hit - truncation * u - [ox, oy]) / res
        b = (hit + truncation * u - [ox, oy]) / res
        for c, r in _cells_on_segment(a[0], a[1], b[0], b[1]):
            if not (0 <= c < cols and 0 <= r < rows) or stamp[r, c] == scan_id:
                continue
            stamp[r, c] = scan_id
            centre = np.array([ox + (c + 0.5) * res, oy + (r + 0.5) * res])
            d = (centre - hit) @ nvec
            d = float(np.clip(d, -truncation, truncation))
            w = w_angle * kernel(d, distance_bandwidth)
            if w <= 0:
                continue
            total = weight[r, c] + w
            tsd[r, c] = (tsd[r, c] * weight[r, c] + d * w) / total
            weight[r, c] = min(total, max_weight)
            n_upd += 1
    match[...] = 1.0 - tsd / truncation
    return n_upd
