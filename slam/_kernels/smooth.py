"""Angular smoothing of a lidar scan: each beam's point replaced by the mean point of its
2*half+1 neighbouring beams (slam.preprocess uses it against range noise).

smooth_ranges: compiled; smooth_ranges_ref: vectorised numpy, for tests.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["smooth_ranges", "smooth_ranges_ref"]


@njit(cache=True, nogil=True)
def smooth_ranges(ranges, valid, half, jump, step, circular):
    """ranges: (B,) m; valid: (B,) bool; step: rad between beams; circular: beam B-1 neighbours
    beam 0. Neighbours invalid or with |r_j - r_i| > jump * r_i (an occluding edge) are left
    out. Returns (along (B,), across (B,)) m: the mean point in the centre beam's frame."""
    B = ranges.shape[0]
    along = np.zeros(B)
    across = np.zeros(B)
    cs = np.empty(2 * half + 1)
    sn = np.empty(2 * half + 1)
    for k in range(-half, half + 1):
        cs[k + half] = np.cos(k * step)
        sn[k + half] = np.sin(k * step)
    for i in range(B):
        if not valid[i]:
            continue
        ri = ranges[i]
        sa = 0.0
        sc = 0.0
        n = 0
        for k in range(-half, half + 1):
            j = i + k
            if circular:
                j = j % B
            elif j < 0 or j >= B:
                continue
            if not valid[j]:
                continue
            rj = ranges[j]
            if abs(rj - ri) > jump * ri:
                continue
            sa += rj * cs[k + half]
            sc += rj * sn[k + half]
            n += 1
        along[i] = sa / n
        across[i] = sc / n
    return along, across


def smooth_ranges_ref(ranges, valid, half, jump, step, circular=True):
    """Reference: the same mean over shifted copies of the whole scan."""
    B = len(ranges)
    r = np.where(valid, ranges, 0.0)
    along = np.zeros(B)
    across = np.zeros(B)
    count = np.zeros(B)
    idx = np.arange(B)
    for k in range(-half, half + 1):
        j = idx + k
        inside = np.ones(B, bool) if circular else (j >= 0) & (j < B)
        j = np.mod(j, B)
        rk = r[j]
        ok = valid & valid[j] & inside & (np.abs(rk - r) <= jump * r)
        along += np.where(ok, rk * np.cos(k * step), 0.0)
        across += np.where(ok, rk * np.sin(k * step), 0.0)
        count += ok
    count = np.maximum(count, 1)
    return along / count, across / count
