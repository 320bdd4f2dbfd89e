"""Gauss-Newton refinement of a particle's matched pose on its own count map (Hector's matcher,
Kohlbrecher et al. 2011, inside Gmapping's improved proposal; Grisetti et al. 2007 leave the
scan matcher open, and the benchmark's issue names "the same Gauss-Newton matcher").

Gmapping's hill climb scores a beam by exp(-d^2 / sigma) against the nearest mean hit point of
the occupied cells around it; with the LDS-01's range noise (2.5 % of the range) that score is
flat within a cell, and the climb stops centimetres and degrees off. The refinement reads the
particle's count map as a reflectance map, M = hits / visits per cell (0 where nothing was
seen, hector_slam's GridMapReflectanceCount), interpolated bilinearly, and runs Hector's
Gauss-Newton steps on sum_i (1 - M(S_i(pose)))^2 from the hill climb's pose, with the motion
prior added as a quadratic pull (slam.pf.proposal).

The mean-hit reading: the ridge of hits / visits lies on cell centres, while a wall's face
lies wherever its returns fall inside the cell (the cells keep the sum of their hit points,
as Gmapping's do). At each scan point the map is read shifted by the hits-weighted
offset of the mean hit points from the cell centres around it (the four cells of the bilinear
interpolation), taken along the map gradient only (the wall's normal), so the ridge lies at
the mean hit points.

The map patch is slam.pf._map_kernel.read_patch's: prob = hits / visits, the hit counts and
each cell's mean hit point as an offset from its lower-left corner.

mean_hit_normal_equations, mean_hit_iterate: compiled; mean_hit_normal_equations_ref: numpy,
for tests.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from slam._kernels.gauss_newton import gn_update
from slam._kernels.interp import add_normal_row, interp_point, interp_value_grad_ref, symmetrize_upper

__all__ = ["mean_hit_normal_equations", "mean_hit_normal_equations_ref", "mean_hit_iterate"]


@njit(cache=True, nogil=True)
def _normal_offset(prob, hits, mean_off, ox, oy, res, rows, cols, x, y):
    """The hits-weighted mean offset of the four cells' mean hit points from their centres
    around (x, y), along the map gradient there; (0, 0) where none of them has a hit or the
    map is flat."""
    u = (x - ox) / res - 0.5
    v = (y - oy) / res - 0.5
    i = int(np.floor(u))
    j = int(np.floor(v))
    if i < 0 or j < 0 or i + 1 >= cols or j + 1 >= rows:
        return 0.0, 0.0
    fu = u - i
    fv = v - j
    wsum = 0.0
    dx = 0.0
    dy = 0.0
    for a in range(2):
        for b in range(2):
            w = (fv if a == 1 else 1.0 - fv) * (fu if b == 1 else 1.0 - fu) * hits[j + a, i + b]
            wsum += w
            dx += w * (mean_off[j + a, i + b, 0] - 0.5 * res)
            dy += w * (mean_off[j + a, i + b, 1] - 0.5 * res)
    if wsum <= 0.0:
        return 0.0, 0.0
    _, gx, gy = interp_point(prob, ox, oy, res, rows, cols, x, y)
    g2 = gx * gx + gy * gy
    if g2 <= 0.0:
        return 0.0, 0.0
    along = (dx * gx + dy * gy) / wsum / g2
    return along * gx, along * gy


@njit(cache=True, nogil=True)
def mean_hit_normal_equations(prob, hits, mean_off, grid_meta, pts_robot, pose):
    """Hector's normal equations (slam/_kernels/gauss_newton.py) with the map read at each point
    moved back by its normal offset to the mean hit points. prob, hits (R, C), mean_off
    (R, C, 2): the patch (read_patch); grid_meta: its [ox, oy, resolution, R, C].
    Returns H (3, 3), g (3,), cost."""
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols = int(grid_meta[3]), int(grid_meta[4])
    c, s = np.cos(pose[2]), np.sin(pose[2])
    H = np.zeros((3, 3))
    g = np.zeros(3)
    cost = 0.0
    for k in range(pts_robot.shape[0]):
        px, py = pts_robot[k, 0], pts_robot[k, 1]
        wx = pose[0] + c * px - s * py
        wy = pose[1] + s * px + c * py
        dx, dy = _normal_offset(prob, hits, mean_off, ox, oy, res, rows, cols, wx, wy)
        m, gx, gy = interp_point(prob, ox, oy, res, rows, cols, wx - dx, wy - dy)
        r = 1.0 - m
        cost += r * r
        add_normal_row(H, g, gx, gy, gx * (-s * px - c * py) + gy * (c * px - s * py), r)
    symmetrize_upper(H)
    return H, g, cost


def mean_hit_normal_equations_ref(prob, hits, mean_off, grid_meta, pts_robot, pose):
    """Reference of mean_hit_normal_equations, vectorised with numpy."""
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    prob, hits = np.asarray(prob, dtype=np.float64), np.asarray(hits, dtype=np.float64)
    off_x = np.where(hits > 0, mean_off[..., 0] - 0.5 * res, 0.0)
    off_y = np.where(hits > 0, mean_off[..., 1] - 0.5 * res, 0.0)
    rows, cols = int(grid_meta[3]), int(grid_meta[4])
    c, s = np.cos(pose[2]), np.sin(pose[2])
    pts = np.asarray(pts_robot, dtype=np.float64).reshape(-1, 2)
    world = pts @ np.array([[c, -s], [s, c]]).T + pose[:2]
    u = (world[:, 0] - ox) / res - 0.5
    v = (world[:, 1] - oy) / res - 0.5
    i, j = np.floor(u).astype(int), np.floor(v).astype(int)
    inside = (i >= 0) & (j >= 0) & (i + 1 < cols) & (j + 1 < rows)
    ii, jj = np.where(inside, i, 0), np.where(inside, j, 0)
    fu, fv = u - i, v - j
    wsum = np.zeros(len(pts))
    d = np.zeros((len(pts), 2))
    for a, wa in ((0, 1 - fv), (1, fv)):
        for b, wb in ((0, 1 - fu), (1, fu)):
            w = wa * wb * hits[jj + a, ii + b] * inside
            wsum += w
            d += w[:, None] * np.stack([off_x[jj + a, ii + b], off_y[jj + a, ii + b]], axis=1)
    grad = interp_value_grad_ref(prob, grid_meta, world)[:, 1:]
    g2 = np.sum(grad ** 2, axis=1)
    ok = (wsum > 0) & (g2 > 0)
    along = np.where(ok, np.einsum("ij,ij->i", d, grad) / np.where(ok, wsum * g2, 1.0), 0.0)
    shifted = world - along[:, None] * grad
    mg = interp_value_grad_ref(prob, grid_meta, shifted)
    J = np.column_stack([mg[:, 1], mg[:, 2], np.einsum("ij,ij->i", mg[:, 1:],
                                                        pts @ np.array([[-s, -c], [c, -s]]).T)])
    r = 1.0 - mg[:, 0]
    return J.T @ J, J.T @ r, float(r @ r)


@njit(cache=True, nogil=True)
def mean_hit_iterate(prob, hits, mean_off, grid_meta, pts_robot, pose, iterations,
                     max_angle_step, prior, prior_info):
    """gauss_newton.gn_iterate's steps (gn_update) on mean_hit_normal_equations; returns the (3,)
    pose."""
    est = pose.copy()
    for _ in range(iterations):
        H, g, _ = mean_hit_normal_equations(prob, hits, mean_off, grid_meta, pts_robot, est)
        if not gn_update(H, g, est, prior, prior_info, max_angle_step):
            break
    return est
