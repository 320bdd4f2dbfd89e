"""Point filters of Cartographer's local SLAM: voxel filter and adaptive voxel filter.

voxel_filter / adaptive_voxel_filter run the compiled kernels of slam.graph._voxel_kernel; the
`_ref` functions are the plain-numpy statements the tests compare them with."""
from __future__ import annotations

import numpy as np

from slam.graph._voxel_kernel import MINSTD_A, MINSTD_M, adaptive_voxel_filter_kernel, voxel_filter_kernel

__all__ = ["voxel_filter", "adaptive_voxel_filter", "voxel_filter_ref", "adaptive_voxel_filter_ref"]


def _rows(points: np.ndarray) -> np.ndarray:
    """Points as contiguous float64 rows (N, 2 or more: x, y, then what travels with them)."""
    a = np.ascontiguousarray(points, dtype=np.float64)
    return a.reshape(-1, 2) if a.ndim == 1 else a


def voxel_filter(points: np.ndarray, size: float, randomized: bool = False) -> np.ndarray:
    """(N, 2) m -> one point of each occupied voxel of `size` m, in input order: the first, or
    (randomized) one drawn uniformly and reproducibly (see voxel_filter_ref). Columns after x
    and y (e.g. a normal) are kept with their points."""
    return voxel_filter_kernel(_rows(points), float(size), bool(randomized))


def adaptive_voxel_filter(points: np.ndarray, max_length: float, min_num_points: int,
                          max_range: float, randomized: bool = False) -> np.ndarray:
    """Cartographer's AdaptiveVoxelFilter (see adaptive_voxel_filter_ref); columns after x and y
    are kept with their points."""
    return adaptive_voxel_filter_kernel(_rows(points), float(max_length), int(min_num_points), float(max_range),
                                        bool(randomized))


def _minstd_keys_ref(n: int) -> np.ndarray:
    """The first n outputs of minstd started at 1, in closed form: key i is A^(i+1) mod M."""
    return np.array([pow(MINSTD_A, i + 1, MINSTD_M) for i in range(n)], dtype=np.int64)


def voxel_filter_ref(points: np.ndarray, size: float, randomized: bool = False) -> np.ndarray:
    """(N, 2) m -> one point of each occupied voxel of `size` m, in input order.

    Not randomized: the first point of the voxel. Randomized (Cartographer's
    RandomizedVoxelFilter): the point with the smallest key of the minimal standard generator
    started at 1, a uniform draw among the voxel's points that does not favour the first
    beams of a scan (keeping the first point shifts every kept point toward the start of the
    sweep, a small rotation of the whole scan)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(points) == 0 or size <= 0:
        return points
    keys = np.floor(points / size).astype(np.int64)
    keys -= keys.min(axis=0)
    # one integer per voxel: 1-D unique is much faster than unique over rows
    flat = keys[:, 0] * (int(keys[:, 1].max()) + 1) + keys[:, 1]
    if not randomized:
        _, first = np.unique(flat, return_index=True)
        return points[np.sort(first)]
    order = np.lexsort((_minstd_keys_ref(len(points)), flat))
    lead = np.r_[True, flat[order[1:]] != flat[order[:-1]]]
    return points[np.sort(order[lead])]


def adaptive_voxel_filter_ref(points: np.ndarray, max_length: float, min_num_points: int,
                              max_range: float, randomized: bool = False) -> np.ndarray:
    """Cartographer's AdaptiveVoxelFilter: the largest voxel size <= max_length that keeps at
    least min_num_points points (bisection over the size), after dropping points beyond
    max_range (m). Few points in, all of them out."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    points = points[np.hypot(points[:, 0], points[:, 1]) <= max_range]
    if len(points) <= min_num_points:
        return points
    result = voxel_filter_ref(points, max_length, randomized)
    if len(result) >= min_num_points:
        return result
    hi, lo = max_length, max_length / 2
    # Halve until enough points survive, then bisect between the two sizes (as Cartographer).
    while lo > 1e-3:
        cand = voxel_filter_ref(points, lo, randomized)
        if len(cand) >= min_num_points:
            result = cand
            break
        hi, lo = lo, lo / 2
    else:
        return points
    for _ in range(5):
        mid = 0.5 * (lo + hi)
        cand = voxel_filter_ref(points, mid, randomized)
        if len(cand) >= min_num_points:
            result, lo = cand, mid
        else:
            hi = mid
    return result
