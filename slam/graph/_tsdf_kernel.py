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
The same ray also updates the directional layers (a directional TSDF, Splietker and Behnke
2019, in 2D): K more fields, one per normal direction 2 pi k / K, each updated only by hits
whose normal lies within 2 pi / K of its direction, with the weight times 1 - (the angle
between them) / (2 pi / K) (direction_mix), each with its own once-per-scan stamp. The two
faces of a thin wall, whose normals are opposite, then fill different layers, where the one
field averages the band behind each face into the other face's cells.

cells_under: the cells under points (the lookups of the matchers' weights and checks).

*_ref: plain numpy/python statements of the same for the tests.
grid meta: (5,) [ox, oy, resolution, rows, cols]; arrays [row, col], row 0 at the bottom.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from slam._kernels.insert import _cells_on_segment, _traverse

__all__ = ["estimate_normals", "tsdf_insert", "cells_under", "direction_mix", "direction_mixes",
           "estimate_normals_ref", "tsdf_insert_ref", "cells_under_ref", "direction_mix_ref"]

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
def direction_mix(normal, directions):
    """(k0, share of k0, k1, share of k1): the two directional layers of `directions` (K > 0)
    a normal angle (rad) falls between, shares linear in the angle, summing to 1."""
    u = (normal / (2.0 * math.pi)) % 1.0 * directions
    k0 = int(math.floor(u))
    f = u - k0
    k0 = k0 % directions
    return k0, 1.0 - f, (k0 + 1) % directions, f


@njit(cache=True, nogil=True)
def direction_mixes(normals, directions):
    """(N, 4) direction_mix of each normal angle (N,) rad: k0, share, k1, share (as floats)."""
    out = np.empty((normals.shape[0], 4))
    for n in range(normals.shape[0]):
        k0, a0, k1, a1 = direction_mix(normals[n], directions)
        out[n, 0] = k0
        out[n, 1] = a0
        out[n, 2] = k1
        out[n, 3] = a1
    return out


@njit(cache=True, nogil=True)
def _update(tsd, weight, r, c, d, w, max_weight):
    w0 = weight[r, c]
    total = w0 + w
    tsd[r, c] = (tsd[r, c] * w0 + d * w) / total
    weight[r, c] = min(total, max_weight)


@njit(cache=True, nogil=True)
def tsdf_insert(tsd, weight, stamp, match, scan_id, meta, origin, hits, normals, truncation, max_weight,
                angle_bandwidth, distance_bandwidth, dir_tsd, dir_weight, dir_stamp):
    """Insert one scan's hits (N, 2) (bearing order) with their normals (N,) from origin (2,).
    tsd, weight (rows, cols) float64 and stamp (rows, cols) int32 are updated in place, and
    match (rows, cols) float64, which holds 1 - tsd / truncation, kept so in every cell
    whose tsd changes; dir_tsd, dir_weight (K, rows, cols) float64 and dir_stamp (K, rows,
    cols) int32 the directional layers (K = 0: none). Returns the number of cell updates of
    the one field."""
    ox, oy, res = meta[0], meta[1], meta[2]
    rows, cols = int(meta[3]), int(meta[4])
    n_dir = dir_tsd.shape[0]
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
        k0, a0, k1, a1 = direction_mix(normals[h], n_dir) if n_dir > 0 else (0, 0.0, 0, 0.0)
        k = _traverse((hx - truncation * ux - ox) / res, (hy - truncation * uy - oy) / res,
                      (hx + truncation * ux - ox) / res, (hy + truncation * uy - oy) / res, path)
        for q in range(k):
            c, r = path[q, 0], path[q, 1]
            if c < 0 or r < 0 or c >= cols or r >= rows:
                continue
            fresh = stamp[r, c] != scan_id
            if not fresh and (n_dir == 0 or (dir_stamp[k0, r, c] == scan_id and dir_stamp[k1, r, c] == scan_id)):
                continue
            cx = ox + (c + 0.5) * res
            cy = oy + (r + 0.5) * res
            d = (cx - hx) * nx + (cy - hy) * ny
            d = min(max(d, -truncation), truncation)
            w = w_angle * _kernel(d, distance_bandwidth)
            if fresh:
                stamp[r, c] = scan_id
                if w > 0.0:
                    _update(tsd, weight, r, c, d, w, max_weight)
                    match[r, c] = 1.0 - tsd[r, c] / truncation
                    n_upd += 1
            for kk, a in ((k0, a0), (k1, a1)):
                if n_dir > 0 and a > 0.0 and dir_stamp[kk, r, c] != scan_id:
                    dir_stamp[kk, r, c] = scan_id
                    if w > 0.0:
                        _update(dir_tsd[kk], dir_weight[kk], r, c, d, w * a, max_weight)
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


def direction_mix_ref(normal, directions):
    """Reference of direction_mix."""
    step = 2 * np.pi / directions
    k0 = int(np.floor(np.mod(normal, 2 * np.pi) / step)) % directions
    f = (np.mod(normal, 2 * np.pi) - k0 * step) / step
    return k0, 1.0 - f, (k0 + 1) % directions, f


def tsdf_insert_ref(tsd, weight, stamp, match, scan_id, meta, origin, hits, normals, truncation, max_weight,
                    angle_bandwidth, distance_bandwidth, dir_tsd, dir_weight, dir_stamp):
    """Reference of tsdf_insert (cells of each ray from the sorted grid-line crossings): the
    one field, then each directional layer as a field of its own fed the hits with their
    share of the layer."""
    n_upd = _field_ref(tsd, weight, stamp, scan_id, meta, origin, hits, normals, np.ones(len(hits)), truncation,
                       max_weight, angle_bandwidth, distance_bandwidth)
    match[...] = 1.0 - tsd / truncation
    n_dir = dir_tsd.shape[0]
    for k in range(n_dir):
        share = np.zeros(len(hits))
        for h, normal in enumerate(normals):
            k0, a0, k1, a1 = direction_mix_ref(normal, n_dir)
            share[h] = a0 if k0 == k else (a1 if k1 == k else 0.0)
        _field_ref(dir_tsd[k], dir_weight[k], dir_stamp[k], scan_id, meta, origin, hits, normals, share, truncation,
                   max_weight, angle_bandwidth, distance_bandwidth)
    return n_upd


def _field_ref(tsd, weight, stamp, scan_id, meta, origin, hits, normals, share, truncation, max_weight,
               angle_bandwidth, distance_bandwidth):
    """One field's insertion of the hits, each update's weight times the hit's share (hits
    with share 0 left out)."""
    def kernel(x, bw):
        return 1.0 if bw <= 0 else np.exp(-0.5 * (x / bw) ** 2) / (np.sqrt(2 * np.pi) * bw)

    ox, oy, res, rows, cols = meta
    origin = np.asarray(origin, float)
    n_upd = 0
    for hit, normal, part in zip(np.asarray(hits, float), normals, share):
        ray = hit - origin
        rng = np.hypot(*ray)
        if rng < truncation or part <= 0:
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
            w = w_angle * kernel(d, distance_bandwidth) * part
            if w <= 0:
                continue
            total = weight[r, c] + w
            tsd[r, c] = (tsd[r, c] * weight[r, c] + d * w) / total
            weight[r, c] = min(total, max_weight)
            n_upd += 1
    return n_upd
