"""Point filters of Cartographer's local SLAM: voxel filter and adaptive voxel filter.

voxel_filter / adaptive_voxel_filter run the compiled kernels of slam._kernels.voxel; the
`_ref` functions are the plain-numpy statements the tests compare them with."""
from __future__ import annotations

import numpy as np

from slam._kernels.voxel import adaptive_voxel_filter_kernel, voxel_filter_kernel

__all__ = ["voxel_filter", "adaptive_voxel_filter", "voxel_filter_ref", "adaptive_voxel_filter_ref"]


def voxel_filter(points: np.ndarray, size: float) -> np.ndarray:
    """(N, 2) m -> the first point of each occupied voxel of `size` m, in input order."""
    return voxel_filter_kernel(np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2), float(size))


def adaptive_voxel_filter(points: np.ndarray, max_length: float, min_num_points: int,
                          max_range: float) -> np.ndarray:
    """Cartographer's AdaptiveVoxelFilter (see adaptive_voxel_filter_ref)."""
    return adaptive_voxel_filter_kernel(np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2),
                                        float(max_length), int(min_num_points), float(max_range))


def voxel_filter_ref(points: np.ndarray, size: float) -> np.ndarray:
    """(N, 2) m -> the first point of each occupied voxel of `size` m, in input order."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(points) == 0 or size <= 0:
        return points
    keys = np.floor(points / size).astype(np.int64)
    keys -= keys.min(axis=0)
    # one integer per voxel: 1-D unique is much faster than unique over rows
    flat = keys[:, 0] * (int(keys[:, 1].max()) + 1) + keys[:, 1]
    _, first = np.unique(flat, return_index=True)
    return points[np.sort(first)]


def adaptive_voxel_filter_ref(points: np.ndarray, max_length: float, min_num_points: int,
                              max_range: float) -> np.ndarray:
    """Cartographer's AdaptiveVoxelFilter: the largest voxel size <= max_length that keeps at
    least min_num_points points (bisection over the size), after dropping points beyond
    max_range (m). Few points in, all of them out."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    points = points[np.hypot(points[:, 0], points[:, 1]) <= max_range]
    if len(points) <= min_num_points:
        return points
    result = voxel_filter_ref(points, max_length)
    if len(result) >= min_num_points:
        return result
    hi, lo = max_length, max_length / 2
    # Halve until enough points survive, then bisect between the two sizes (as Cartographer).
    while lo > 1e-3:
        cand = voxel_filter_ref(points, lo)
        if len(cand) >= min_num_points:
            result = cand
            break
        hi, lo = lo, lo / 2
    else:
        return points
    for _ in range(5):
        mid = 0.5 * (lo + hi)
        cand = voxel_filter_ref(points, mid)
        if len(cand) >= min_num_points:
            result, lo = cand, mid
        else:
            hi = mid
    return result
