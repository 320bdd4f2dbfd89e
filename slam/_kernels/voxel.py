"""Voxel filters of the pose-graph SLAM's local SLAM, compiled.

voxel_filter_kernel / adaptive_voxel_filter_kernel: the same results as the plain-numpy
slam.graph.filters.voxel_filter_ref / adaptive_voxel_filter_ref (tests compare them). The
adaptive filter bisects over the voxel size with up to ~20 filter passes per scan; in numpy
each pass costs more in call overhead than in arithmetic, so the whole search runs here.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["voxel_filter_kernel", "adaptive_voxel_filter_kernel"]


@njit(cache=True)
def voxel_filter_kernel(points, size):
    """(N, 2) float64 -> the first point of each occupied voxel of `size`, in input order."""
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
    prev = -1
    for q in range(n):
        i = order[q]
        if q == 0 or flat[i] != prev:
            keep[i] = True
            prev = flat[i]
    return points[keep]


@njit(cache=True)
def adaptive_voxel_filter_kernel(points, max_length, min_num_points, max_range):
    """Cartographer's AdaptiveVoxelFilter (see slam.graph.filters.adaptive_voxel_filter_ref)."""
    n = points.shape[0]
    inside = np.empty(n, np.bool_)
    for i in range(n):
        inside[i] = np.hypot(points[i, 0], points[i, 1]) <= max_range
    pts = points[inside]
    if pts.shape[0] <= min_num_points:
        return pts
    result = voxel_filter_kernel(pts, max_length)
    if result.shape[0] >= min_num_points:
        return result
    hi = max_length
    lo = max_length / 2
    found = False
    while lo > 1e-3:
        cand = voxel_filter_kernel(pts, lo)
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
        cand = voxel_filter_kernel(pts, mid)
        if cand.shape[0] >= min_num_points:
            result = cand
            lo = mid
        else:
            hi = mid
    return result
