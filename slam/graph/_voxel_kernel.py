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
def voxel_filter_kernel(points, size, randomized=False):
    """(N, 2) float64 -> one point of each occupied voxel of `size`, in input order: the
    first, or (randomized) the one with the smallest minstd key."""
    n = points.shape[0]
    if n == 0 or size <= 0:
        return points.copy()
    kx = np.empty(n, np.int64)
    ky = np.empty(n, np.int64)
    for i in range(n):
        kx[i] = np.int64(np.floor(points[i, 0] / size))
        ky[i] = np.int64(np.floor(points[i, 1] / size))
    kx -= kx.min()
    ky -= ky.min()
    span = ky.max() + 1
    flat = kx * span + ky
    order = np.argsort(flat, kind="mergesort")   # stable: the first of equal keys comes first
    keep = np.zeros(n, np.bool_)
    if not randomized:
        prev = -1
        for q in range(n):
            i = order[q]
            if q == 0 or flat[i] != prev:
                keep[i] = True
                prev = flat[i]
        return points[keep]
    rnd = _minstd_keys(n)
    q = 0
    while q < n:
        best = order[q]
        e = q + 1
        while e < n and flat[order[e]] == flat[best]:
            if rnd[order[e]] < rnd[best]:
                best = order[e]
            e += 1
        keep[best] = True
        q = e
    return points[keep]


@njit(cache=True, nogil=True)
def adaptive_voxel_filter_kernel(points, max_length, min_num_points, max_range, randomized=False):
    """Cartographer's AdaptiveVoxelFilter (see slam.graph.filters.adaptive_voxel_filter_ref)."""
    n = points.shape[0]
    inside = np.empty(n, np.bool_)
    for i in range(n):
        inside[i] = np.hypot(points[i, 0], points[i, 1]) <= max_range
    pts = points[inside]
    if pts.shape[0] <= min_num_points:
        return pts
    result = voxel_filter_kernel(pts, max_length, randomized)
    if result.shape[0] >= min_num_points:
        return result
    hi = max_length
    lo = max_length / 2
    found = False
    while lo > 1e-3:
        cand = voxel_filter_kernel(pts, lo, randomized)
        if cand.shape[0] >= min_num_points:
            result = cand
            found = True
            break
        hi = lo
        lo = lo / 2
    if not found:
        return pts
    for _ in range(5):
        mid = 0.5 * (lo + hi)
        cand = voxel_filter_kernel(pts, mid, randomized)
        if cand.shape[0] >= min_num_points:
            result = cand
            lo = mid
        else:
            hi = mid
    return result
