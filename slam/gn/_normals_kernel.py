"""Surface normals of a scan's points, and how well their directions pin a translation.

A point's normal is the direction of least spread of itself and up to `half` neighbouring
points to either side in scan order (principal axes of the 2x2 scatter), taken only from
neighbours that lie within `max_gap` m per beam step of it, so that points across an
occluding edge do not tilt it. The mean outer product of the normals, A = sum n n^T / N,
says which translations the scan's geometry constrains: along two parallel walls its
smaller eigenvalue is near 0 (gn's degeneracy check, Zhang, Kaess and Singh, ICRA 2016).

Not graph's Cartographer normal estimation (slam/graph/_tsdf_kernel.py: the mean of the
segment normals to neighbours within a radius, the ray direction where there are none): a
point with no usable neighbour carries no direction here, not the ray's.

scan_normals: compiled; scan_normals_ref: numpy (eigh per point), for tests.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["scan_normals", "scan_normals_ref", "normal_information"]


@njit(cache=True, nogil=True)
def scan_normals(points, half, max_gap):
    """points: (N, 2) m in scan order. Returns (N, 2) unit normals (sign arbitrary); a zero row
    where fewer than 3 points (the point and its usable neighbours) are left."""
    n = points.shape[0]
    out = np.zeros((n, 2))
    for i in range(n):
        a = max(i - half, 0)
        b = min(i + half, n - 1)
        px, py = points[i, 0], points[i, 1]
        while a < i and np.hypot(points[a, 0] - px, points[a, 1] - py) > max_gap * (i - a):
            a += 1
        while b > i and np.hypot(points[b, 0] - px, points[b, 1] - py) > max_gap * (b - i):
            b -= 1
        if b - a < 2:
            continue
        mx = 0.0
        my = 0.0
        for k in range(a, b + 1):
            mx += points[k, 0]
            my += points[k, 1]
        m = b - a + 1
        mx /= m
        my /= m
        sxx = 0.0
        sxy = 0.0
        syy = 0.0
        for k in range(a, b + 1):
            dx = points[k, 0] - mx
            dy = points[k, 1] - my
            sxx += dx * dx
            sxy += dx * dy
            syy += dy * dy
        # the axis of largest spread is at theta; the normal is perpendicular to it
        theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
        out[i, 0] = -np.sin(theta)
        out[i, 1] = np.cos(theta)
    return out


def scan_normals_ref(points, half, max_gap):
    """Reference: the same neighbour window, normal = np.linalg.eigh's smallest eigenvector."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = len(p)
    out = np.zeros((n, 2))
    for i in range(n):
        lo = [k for k in range(max(i - half, 0), i)]
        hi = [k for k in range(min(i + half, n - 1), i, -1)]
        a = next((k for k in lo if np.linalg.norm(p[k] - p[i]) <= max_gap * (i - k)), i)
        b = next((k for k in hi if np.linalg.norm(p[k] - p[i]) <= max_gap * (k - i)), i)
        if b - a < 2:
            continue
        q = p[a:b + 1] - p[a:b + 1].mean(axis=0)
        out[i] = np.linalg.eigh(q.T @ q)[1][:, 0]
    return out


def normal_information(normals: np.ndarray) -> np.ndarray:
    """(2, 2) mean outer product of the normals (zero rows count, as points without a normal)."""
    nrm = np.asarray(normals, dtype=np.float64).reshape(-1, 2)
    if len(nrm) == 0:
        return np.zeros((2, 2))
    return nrm.T @ nrm / len(nrm)
