"""Gauss-Newton refinement of a particle's matched pose on its own count map, inside Gmapping's
improved proposal (Grisetti et al. 2007 leave the scan matcher open): point-to-line distances
to the walls the map's mean hit points draw, as in Censi's PL-ICP, with the motion prior added
as a quadratic pull (slam.pf.proposal).

Gmapping's hill climb scores a beam by exp(-d^2 / sigma) against the nearest mean hit point of
the occupied cells around it. One mean hit point per cell makes that score a sawtooth along a
wall (a beam's nearest point jumps from cell to cell), and on a map drawn from the true poses
the climb stops millimetres to a centimetre away from a pose it started at. The refinement keeps
Gmapping's pairing (the nearest mean hit point among the matching candidates: occupied cells
whose free-point cell is not) and measures each end point's distance to the wall through that
cell: the principal axis of the mean hit points of the occupied cells in its 3x3 block,
weighted by their hit counts. Where the block is no line (a corner, a pillar, a lone cell) the
distance to the point itself is used. Residuals are in map cells, Huber weighted beyond half a
cell, so a wrong pairing pulls with a bounded force.

The normal equations at the refined pose, prior included, are the information of the Laplace
approximation of likelihood x prior there: the proposal draws from that Gaussian
(slam.pf._proposal_kernel), so the particles spread where the scan leaves the pose open
(along a corridor) and agree where the walls fix it.

The map patch is slam.pf._map_kernel.read_patch's: prob = hits / visits, the hit counts and
each cell's mean hit point as an offset from its lower-left corner.

line_normal_equations, line_iterate: compiled; line_normal_equations_ref: a plain loop, for
tests.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from slam._kernels.gauss_newton import add_prior, gn_update
from slam._kernels.interp import add_normal_row, symmetrize_upper

__all__ = ["line_normal_equations", "line_normal_equations_ref", "line_iterate", "HUBER_CELLS"]

# residuals beyond this many cells are Huber weighted
HUBER_CELLS = 0.5


@njit(cache=True, nogil=True)
def _wall_normal(prob, hit_count, mean_off, ox, oy, res, r, c, fullness):
    """Unit normal of the principal axis of the mean hit points of the occupied cells in the 3x3
    block around patch cell (r, c), weighted by their hit counts, and whether the block is a
    line: False where fewer than two cells are occupied or the points spread across the
    axis more than a quarter as much as along it."""
    rows, cols = prob.shape
    n = 0
    sw = sx = sy = sxx = sxy = syy = 0.0
    for a in range(-1, 2):
        rr = r + a
        if rr < 0 or rr >= rows:
            continue
        for b in range(-1, 2):
            cc = c + b
            if cc < 0 or cc >= cols or not prob[rr, cc] > fullness:
                continue
            w = hit_count[rr, cc]
            x = ox + cc * res + mean_off[rr, cc, 0]
            y = oy + rr * res + mean_off[rr, cc, 1]
            n += 1
            sw += w
            sx += w * x
            sy += w * y
            sxx += w * x * x
            sxy += w * x * y
            syy += w * y * y
    if n < 2 or sw <= 0.0:
        return 0.0, 0.0, False
    mx, my = sx / sw, sy / sw
    cxx = sxx / sw - mx * mx
    cxy = sxy / sw - mx * my
    cyy = syy / sw - my * my
    half_tr = 0.5 * (cxx + cyy)
    disc = math.sqrt(max(0.25 * (cxx - cyy) ** 2 + cxy * cxy, 0.0))
    lo, hi = half_tr - disc, half_tr + disc
    if hi <= 0.0 or lo > 0.25 * hi:
        return 0.0, 0.0, False
    theta = 0.5 * math.atan2(2.0 * cxy, cxx - cyy)   # the principal (along-wall) axis
    return -math.sin(theta), math.cos(theta), True


@njit(cache=True, nogil=True)
def _nearest_candidate(prob, mean_off, ox, oy, res, fullness, kernel, hr, hc, dr, dc, wx, wy):
    """The matching candidate (Gmapping's rule) nearest to (wx, wy) in the (2 kernel + 1)^2
    window around patch cell (hr, hc): (found, row, column, its mean hit x, y)."""
    rows, cols = prob.shape
    best = np.inf
    br = bc = 0
    mx = my = 0.0
    for a in range(-kernel, kernel + 1):
        r = hr + a
        if r < 0 or r >= rows:
            continue
        for b in range(-kernel, kernel + 1):
            c = hc + b
            if c < 0 or c >= cols or not prob[r, c] > fullness:
                continue
            fr, fc = r + dr, c + dc
            if 0 <= fr < rows and 0 <= fc < cols and prob[fr, fc] > fullness:
                continue
            x = ox + c * res + mean_off[r, c, 0]
            y = oy + r * res + mean_off[r, c, 1]
            d2 = (wx - x) ** 2 + (wy - y) ** 2
            if d2 < best:
                best, br, bc, mx, my = d2, r, c, x, y
    return best < np.inf, br, bc, mx, my


@njit(cache=True, nogil=True)
def line_normal_equations(prob, hit_count, mean_off, grid_meta, fullness, kernel, pts_robot,
                          free_robot, pose):
    """Normal equations of the scan's point-to-line distances to a particle's map at pose (3,)
    (see the module docstring). prob, hit_count (R, C), mean_off (R, C, 2): the patch
    (read_patch); grid_meta: its [ox, oy, resolution, R, C]; pts_robot, free_robot: (K, 2) end
    points and their free points, robot frame. Returns H (3, 3), g (3,) (the step is
    H^-1 g, as gauss_newton.gn_update takes it) and the cost, in squared cells."""
    known, normals = _normal_cache(prob)
    return _normal_equations(prob, hit_count, mean_off, grid_meta, fullness, kernel, pts_robot,
                             free_robot, pose, known, normals)


@njit(cache=True, nogil=True)
def _normal_cache(prob):
    """Per patch cell: whether its wall normal is known (R, C), and the normal and line flag
    (R, C, 3). A cell's wall is a property of the map, the same at every pose tried."""
    return (np.zeros(prob.shape, dtype=np.bool_),
            np.empty((prob.shape[0], prob.shape[1], 3), dtype=np.float64))


@njit(cache=True, nogil=True)
def _normal_equations(prob, hit_count, mean_off, grid_meta, fullness, kernel, pts_robot,
                      free_robot, pose, known, normals):
    """line_normal_equations with the wall normals of the cells met so far cached in known,
    normals (_normal_cache)."""
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    H = np.zeros((3, 3))
    g = np.zeros(3)
    cost = 0.0
    for k in range(pts_robot.shape[0]):
        px, py = pts_robot[k, 0], pts_robot[k, 1]
        wx = pose[0] + c * px - s * py
        wy = pose[1] + s * px + c * py
        hc = int(math.floor((wx - ox) / res))
        hr = int(math.floor((wy - oy) / res))
        dc = int(math.floor((pose[0] + c * free_robot[k, 0] - s * free_robot[k, 1] - ox) / res)) - hc
        dr = int(math.floor((pose[1] + s * free_robot[k, 0] + c * free_robot[k, 1] - oy) / res)) - hr
        found, br, bc, mx, my = _nearest_candidate(prob, mean_off, ox, oy, res, fullness, kernel,
                                                   hr, hc, dr, dc, wx, wy)
        if not found:
            continue
        ex, ey = -s * px - c * py, c * px - s * py     # d(world point) / d(yaw)
        if not known[br, bc]:
            nx, ny, line = _wall_normal(prob, hit_count, mean_off, ox, oy, res, br, bc, fullness)
            known[br, bc] = True
            normals[br, bc, 0], normals[br, bc, 1] = nx, ny
            normals[br, bc, 2] = 1.0 if line else 0.0
        nx, ny, line = normals[br, bc, 0], normals[br, bc, 1], normals[br, bc, 2] > 0.0
        for q in range(1 if line else 2):
            if line:
                ux, uy = nx, ny
            elif q == 0:
                ux, uy = 1.0, 0.0
            else:
                ux, uy = 0.0, 1.0
            r_m = (ux * (wx - mx) + uy * (wy - my)) / res
            w = 1.0 if abs(r_m) <= HUBER_CELLS else HUBER_CELLS / abs(r_m)
            cost += w * r_m * r_m
            sw = math.sqrt(w) / res
            add_normal_row(H, g, sw * ux, sw * uy, sw * (ux * ex + uy * ey), -math.sqrt(w) * r_m)
    symmetrize_upper(H)
    return H, g, cost


def line_normal_equations_ref(prob, hit_count, mean_off, grid_meta, fullness, kernel, pts_robot,
                              free_robot, pose):
    """Reference of line_normal_equations: numpy per end point, the wall's normal from
    np.linalg.eigh of the block's weighted covariance."""
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols = prob.shape
    c, s = np.cos(pose[2]), np.sin(pose[2])
    J, r_all, w_all = [], [], []
    for (px, py), (fx, fy) in zip(np.asarray(pts_robot, float), np.asarray(free_robot, float)):
        w_pt = np.array([pose[0] + c * px - s * py, pose[1] + s * px + c * py])
        cell = np.floor((w_pt - [ox, oy]) / res).astype(int)          # (column, row)
        f_pt = np.array([pose[0] + c * fx - s * fy, pose[1] + s * fx + c * fy])
        d = np.floor((f_pt - [ox, oy]) / res).astype(int) - cell
        cands = []
        for a in range(-kernel, kernel + 1):
            for b in range(-kernel, kernel + 1):
                rr, cc = cell[1] + a, cell[0] + b
                if not (0 <= rr < rows and 0 <= cc < cols and prob[rr, cc] > fullness):
                    continue
                fr, fc = rr + d[1], cc + d[0]
                if 0 <= fr < rows and 0 <= fc < cols and prob[fr, fc] > fullness:
                    continue
                m = np.array([ox + cc * res + mean_off[rr, cc, 0], oy + rr * res + mean_off[rr, cc, 1]])
                cands.append((float(np.sum((w_pt - m) ** 2)), rr, cc, m))
        if not cands:
            continue
        _, br, bc, m = min(cands, key=lambda t: t[0])
        blk = [(hit_count[rr, cc], ox + cc * res + mean_off[rr, cc, 0], oy + rr * res + mean_off[rr, cc, 1])
               for rr in range(br - 1, br + 2) for cc in range(bc - 1, bc + 2)
               if 0 <= rr < rows and 0 <= cc < cols and prob[rr, cc] > fullness]
        dirs = [np.array([1.0, 0.0]), np.array([0.0, 1.0])]
        if len(blk) >= 2:
            wb = np.array([t[0] for t in blk], float)
            xy = np.array([[t[1], t[2]] for t in blk], float)
            if wb.sum() > 0:
                mu = wb @ xy / wb.sum()
                cov = (wb[:, None] * (xy - mu)).T @ (xy - mu) / wb.sum()
                vals, vecs = np.linalg.eigh(cov)
                if vals[1] > 0 and vals[0] <= 0.25 * vals[1]:
                    dirs = [vecs[:, 0]]
        dyaw = np.array([-s * px - c * py, c * px - s * py])
        for u in dirs:
            r = float(u @ (w_pt - m)) / res
            w = 1.0 if abs(r) <= HUBER_CELLS else HUBER_CELLS / abs(r)
            J.append(np.array([u[0], u[1], u @ dyaw]) / res)
            r_all.append(r)
            w_all.append(w)
    if not J:
        return np.zeros((3, 3)), np.zeros(3), 0.0
    J, r_all, w_all = np.array(J), np.array(r_all), np.array(w_all)
    H = (J * w_all[:, None]).T @ J
    g = -(J * w_all[:, None]).T @ r_all
    return H, g, float(np.sum(w_all * r_all ** 2))


@njit(cache=True, nogil=True)
def line_iterate(prob, hit_count, mean_off, grid_meta, fullness, kernel, pts_robot, free_robot,
                 pose, iterations, max_angle_step, prior, prior_info):
    """gauss_newton.gn_update's steps on line_normal_equations from pose (3,), with the pull
    d^T prior_info d towards prior. Returns the pose (3,) and the information (3, 3) there,
    prior included (the normal equations' H)."""
    est = pose.copy()
    known, normals = _normal_cache(prob)
    for _ in range(iterations):
        H, g, _ = _normal_equations(prob, hit_count, mean_off, grid_meta, fullness, kernel,
                                    pts_robot, free_robot, est, known, normals)
        if not gn_update(H, g, est, prior, prior_info, max_angle_step):
            break
    H, g, _ = _normal_equations(prob, hit_count, mean_off, grid_meta, fullness, kernel,
                                pts_robot, free_robot, est, known, normals)
    add_prior(H, g, est, prior, prior_info)
    return est, H
