"""Bilinear interpolation of an occupancy map and its gradient (Hector SLAM, Kohlbrecher et al. 2011).

The map is a continuous function M(x, y): cell values sit at the cell centres and are
blended bilinearly between the four nearest centres, so M has a gradient everywhere and a
scan can be matched to it by Gauss-Newton. Outside the grid M = 0 with zero gradient.

interp_value_grad: compiled; interp_value_grad_ref: vectorised numpy, for tests.
grid_meta: (5,) [ox, oy, resolution, rows, cols]; prob[row, col], row 0 at the bottom.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["interp_value_grad", "interp_point", "bilinear_cell", "bilinear", "interp_value_grad_ref",
           "add_normal_row", "symmetrize_upper"]


@njit(cache=True, nogil=True)
def bilinear_cell(ox, oy, res, rows, cols, x, y):
    """(i, j, fu, fv): the lower-left of the four cell centres around world point x, y (m),
    column i and row j, and the point's fractions towards the next ones; i = -1 when the four
    are not all inside the grid."""
    u = (x - ox) / res - 0.5  # continuous index with cell centres at integers
    v = (y - oy) / res - 0.5
    i = int(np.floor(u))
    j = int(np.floor(v))
    if i < 0 or j < 0 or i + 1 >= cols or j + 1 >= rows:
        return -1, -1, 0.0, 0.0
    return i, j, u - i, v - j


@njit(cache=True, nogil=True)
def bilinear(p00, p01, p10, p11, fu, fv, res):
    """(M, dM/dx, dM/dy) between four cell values (p01: the next column, p10: the next row)."""
    m = (1.0 - fv) * ((1.0 - fu) * p00 + fu * p01) + fv * ((1.0 - fu) * p10 + fu * p11)
    du = (1.0 - fv) * (p01 - p00) + fv * (p11 - p10)
    dv = (1.0 - fu) * (p10 - p00) + fu * (p11 - p01)
    return m, du / res, dv / res


@njit(cache=True, nogil=True)
def interp_point(prob, ox, oy, res, rows, cols, x, y):
    """(M, dM/dx, dM/dy) at world point x, y (m); gradient per metre."""
    i, j, fu, fv = bilinear_cell(ox, oy, res, rows, cols, x, y)
    if i < 0:
        return 0.0, 0.0, 0.0
    return bilinear(prob[j, i], prob[j, i + 1], prob[j + 1, i], prob[j + 1, i + 1], fu, fv, res)


@njit(cache=True, nogil=True)
def add_normal_row(H, g, j0, j1, j2, r):
    """Add one residual r with Jacobian row (j0, j1, j2) to the upper triangle of the 3x3
    Gauss-Newton matrix H = J^T J and to g = J^T r (the scan matchers' inner loop)."""
    g[0] += j0 * r
    g[1] += j1 * r
    g[2] += j2 * r
    H[0, 0] += j0 * j0
    H[0, 1] += j0 * j1
    H[0, 2] += j0 * j2
    H[1, 1] += j1 * j1
    H[1, 2] += j1 * j2
    H[2, 2] += j2 * j2


@njit(cache=True, nogil=True)
def symmetrize_upper(H):
    """Copy the upper triangle of the 3x3 H into the lower one."""
    H[1, 0] = H[0, 1]
    H[2, 0] = H[0, 2]
    H[2, 1] = H[1, 2]


@njit(cache=True, nogil=True)
def interp_value_grad(prob, grid_meta, pts_xy):
    """prob: (rows, cols) finite values; pts_xy: (N, 2) world m. Returns (N, 3) M, dM/dx, dM/dy."""
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols = int(grid_meta[3]), int(grid_meta[4])
    out = np.empty((pts_xy.shape[0], 3))
    for k in range(pts_xy.shape[0]):
        m, gx, gy = interp_point(prob, ox, oy, res, rows, cols, pts_xy[k, 0], pts_xy[k, 1])
        out[k, 0] = m
        out[k, 1] = gx
        out[k, 2] = gy
    return out


def interp_value_grad_ref(prob, grid_meta, pts_xy):
    """Reference: the same bilinear patch written as a 2x2 matrix product per point."""
    ox, oy, res, rows, cols = grid_meta
    pts = np.asarray(pts_xy, dtype=np.float64).reshape(-1, 2)
    uv = (pts - [ox, oy]) / res - 0.5
    ij = np.floor(uv).astype(np.int64)
    out = np.zeros((len(pts), 3))
    for k, ((u, v), (i, j)) in enumerate(zip(uv, ij)):
        if i < 0 or j < 0 or i + 1 >= cols or j + 1 >= rows:
            continue
        a, b = u - i, v - j
        patch = prob[j:j + 2, i:i + 2]          # [[p00, p01], [p10, p11]]
        wv, wu = np.array([1 - b, b]), np.array([1 - a, a])
        out[k, 0] = wv @ patch @ wu
        out[k, 1] = wv @ patch @ np.array([-1.0, 1.0]) / res
        out[k, 2] = np.array([-1.0, 1.0]) @ patch @ wu / res
    return out
