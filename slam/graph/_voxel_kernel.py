"""Voxel filters of the pose-graph SLAM's local SLAM, compiled.

voxel_filter_kernel / adaptive_voxel_filter_kernel: the same results as the plain-numpy
slam.graph.filters.voxel_filter_ref / adaptive_voxel_filter_ref (tests compare them). The
adaptive filter bisects over the voxel size with up to ~20 filter passes per scan; in numpy
each pass costs more in call overhead than in arithmetic, so the whole search runs here.

A voxel keeps either its first point (input order) or, randomized, one of its points drawn
uniformly (Cartographer's RandomizedVoxelFilter): each point gets a key from the minimal
standard generator (Park & Miller, multiplier 48271) started at 1 on every call, and a voxel
keeps the point with the smallest key, so the result is reproducible.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["voxel_filter_kernel", "adaptive_voxel_filter_kernel", "MINSTD_A", "MINSTD_M"]

MINSTD_A = 48271
MINSTD_M = 2147483647


@njit(cache=True, nogil=True)
def _minstd_keys(n):
    keys = np.empty(n, np.int64)
    x = np.int64(1)
    for i in range(n):
        x = (x * MINSTD_A) % MINSTD_M
        keys[i] = x
    return keys


@njit(cache=True, nogil=True)
def _select(px, py, size, rnd, mark, keep, table_key, table_pt):
    """The number of occupied voxels of `size` of the points (px, py (N,) contiguous, so the
    divisions vectorise); if mark, keep (N,) bool is set to the point each voxel keeps: the
    first, or with rnd (N,) minstd keys (empty: not randomized) the one with the smallest
    key. table_key, table_pt: (cap,) int64 scratch, cap a power of two >= 2N."""
    n = px.shape[0]
    kx = np.empty(n, np.int64)
    ky = np.empty(n, np.int64)
    for i in range(n):
        kx[i] = np.int64(np.floor(px[i] / size))
    for i in range(n):
        ky[i] = np.int64(np.floor(py[i] / size))
    kx -= kx.min()
    ky -= ky.min()
    span = ky.max() + 1
    # Open-addressing hash table voxel -> the point it keeps so far (a sort by voxel would
    # cost n log n per pass of the adaptive filter).
    cap = table_key.shape[0]
    table_key[:] = -1
    count = 0
    for i in range(n):
        key = kx[i] * span + ky[i]
        h = (key ^ (key >> 16)) & (cap - 1)
        while table_key[h] != -1 and table_key[h] != key:
            h = (h + 1) & (cap - 1)
        if table_key[h] == -1:
            table_key[h] = key
            table_pt[h] = i
            count += 1
        elif rnd.shape[0] and rnd[i] < rnd[table_pt[h]]:
            table_pt[h] = i
    if mark:
        keep[:] = False
        for h in range(cap):
            if table_key[h] != -1:
                keep[table_pt[h]] = True
    return count


@njit(cache=True, nogil=True)
def _scratch(n):
    cap = 1
    while cap < 2 * n:
        cap *= 2
    return np.empty(n, np.bool_), np.empty(cap, np.int64), np.empty(cap, np.int64)


@njit(cache=True, nogil=True)
def voxel_filter_kernel(points, size, randomized=False):
    """(N, 2) float64 -> one point of each occupied voxel of `size`, in input order: the
    first, or (randomized) the one with the smallest minstd key."""
    n = points.shape[0]
    if n == 0 or size <= 0:
        return points.copy()
    rnd = _minstd_keys(n) if randomized else np.empty(0, np.int64)
    keep, table_key, table_pt = _scratch(n)
    _select(points[:, 0].copy(), points[:, 1].copy(), size, rnd, True, keep, table_key, table_pt)
    return points[keep]


@njit(cache=True, nogil=True)
def adaptive_voxel_filter_kernel(points, max_length, min_num_points, max_range, randomized=False):
    """Cartographer's AdaptiveVoxelFilter (see slam.graph.filters.adaptive_voxel_filter_ref)."""
    n = points.shape[0]
    inside = np.empty(n, np.bool_)
    for i in range(n):
        inside[i] = np.hypot(points[i, 0], points[i, 1]) <= max_range
    pts = points[inside]
    n = pts.shape[0]
    if n <= min_num_points:
        return pts
    # the voxel filter's passes share the generator keys and scratch; only the size that is
    # kept is turned into points
    rnd = _minstd_keys(n) if randomized else np.empty(0, np.int64)
    keep, table_key, table_pt = _scratch(n)
    px = pts[:, 0].copy()
    py = pts[:, 1].copy()
    if max_length <= 0 or _select(px, py, max_length, rnd, True, keep, table_key, table_pt) >= min_num_points:
        return pts[keep] if max_length > 0 else pts.copy()
    hi = max_length
    lo = max_length / 2
    found = False
    while lo > 1e-3:
        if _select(px, py, lo, rnd, False, keep, table_key, table_pt) >= min_num_points:
            found = True
            break
        hi = lo
        lo = lo / 2
    if not found:
        return pts
    best = lo
    for _ in range(5):
        mid = 0.5 * (lo + hi)
        if _select(px, py, mid, rnd, False, keep, table_key, table_pt) >= min_num_points:
            best = mid
            lo = mid
        else:
            hi = mid
    _select(px, py, best, rnd, True, keep, table_key, table_pt)
    return pts[keep]
