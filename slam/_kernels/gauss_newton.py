"""Normal equations of Hector's scan-to-map Gauss-Newton step (Kohlbrecher et al. 2011, eq. 7-12).

For the scan end points s_i (robot frame) and pose xi = (x, y, yaw), the cost is
sum_i (1 - M(S_i(xi)))^2 with S_i(xi) = R(yaw) s_i + t. One Gauss-Newton step solves
H dxi = g with H = sum J_i^T J_i, g = sum J_i^T (1 - M(S_i)), J_i = grad M(S_i) dS_i/dxi.

Optional surface normals (N, 2) in the robot frame, one per point (gn's
gradient_along_normal, not in Hector): a point with a normal n reads the map gradient
projected onto it, (grad M . R n) R n, so a point on a wall pulls the scan across the wall
and not along it (the point-to-line idea of ICP, Censi 2008); a zero row keeps the full
gradient. An empty (0, 2) array means none.

gn_normal_equations: compiled; gn_normal_equations_ref: numpy, for tests.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from slam._kernels.interp import add_normal_row, interp_point, interp_value_grad_ref, symmetrize_upper

__all__ = ["gn_normal_equations", "gn_normal_equations_ref", "gn_update", "solve3", "gn_iterate",
           "gn_iterate_ref", "NO_NORMALS"]

NO_NORMALS = np.zeros((0, 2))


@njit(cache=True, nogil=True)
def gn_normal_equations(prob, grid_meta, pts_robot, pose, normals=NO_NORMALS):
    """prob: (rows, cols); pts_robot: (N, 2) m; pose: (3,); normals: (N, 2) robot-frame unit
    normals (zero row: none) or (0, 2). Returns H (3, 3), g (3,), cost."""
    ox, oy, res = grid_meta[0], grid_meta[1], grid_meta[2]
    rows, cols = int(grid_meta[3]), int(grid_meta[4])
    c, s = np.cos(pose[2]), np.sin(pose[2])
    use_normals = normals.shape[0] == pts_robot.shape[0]
    H = np.zeros((3, 3))
    g = np.zeros(3)
    cost = 0.0
    for k in range(pts_robot.shape[0]):
        px, py = pts_robot[k, 0], pts_robot[k, 1]
        wx = pose[0] + c * px - s * py
        wy = pose[1] + s * px + c * py
        m, gx, gy = interp_point(prob, ox, oy, res, rows, cols, wx, wy)
        if use_normals and (normals[k, 0] != 0.0 or normals[k, 1] != 0.0):
            nx = c * normals[k, 0] - s * normals[k, 1]
            ny = s * normals[k, 0] + c * normals[k, 1]
            along = gx * nx + gy * ny
            gx = along * nx
            gy = along * ny
        r = 1.0 - m
        j0 = gx
        j1 = gy
        j2 = gx * (-s * px - c * py) + gy * (c * px - s * py)
        cost += r * r
        add_normal_row(H, g, j0, j1, j2, r)
    symmetrize_upper(H)
    return H, g, cost


def gn_normal_equations_ref(prob, grid_meta, pts_robot, pose, normals=None):
    """Reference: vectorised Jacobians, H = J^T J, g = J^T r."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    R = np.array([[c, -s], [s, c]])
    dR = np.array([[-s, -c], [c, -s]])
    pts = np.asarray(pts_robot, dtype=np.float64).reshape(-1, 2)
    world = pts @ R.T + pose[:2]
    mg = interp_value_grad_ref(prob, grid_meta, world)
    grad = mg[:, 1:]
    if normals is not None and len(normals) == len(pts):
        n = np.asarray(normals, dtype=np.float64) @ R.T
        has = np.any(np.asarray(normals) != 0.0, axis=1)
        grad = np.where(has[:, None], np.einsum("ij,ij->i", grad, n)[:, None] * n, grad)
    J = np.column_stack([grad[:, 0], grad[:, 1], np.einsum("ij,ij->i", grad, pts @ dR.T)])
    r = 1.0 - mg[:, 0]
    return J.T @ J, J.T @ r, float(r @ r)


@njit(cache=True, nogil=True)
def solve3(H, g):
    """Solution of the 3x3 system H x = g by Cramer's rule; (zeros, False) when singular."""
    a, b, c = H[0, 0], H[0, 1], H[0, 2]
    d, e, f = H[1, 0], H[1, 1], H[1, 2]
    p, q, r = H[2, 0], H[2, 1], H[2, 2]
    det = a * (e * r - f * q) - b * (d * r - f * p) + c * (d * q - e * p)
    x = np.zeros(3)
    scale = abs(a * e * r) + 1e-300
    if abs(det) <= 1e-12 * scale:
        return x, False
    x[0] = (g[0] * (e * r - f * q) - b * (g[1] * r - f * g[2]) + c * (g[1] * q - e * g[2])) / det
    x[1] = (a * (g[1] * r - f * g[2]) - g[0] * (d * r - f * p) + c * (d * g[2] - g[1] * p)) / det
    x[2] = (a * (e * g[2] - g[1] * q) - b * (d * g[2] - g[1] * p) + g[0] * (d * q - e * p)) / det
    return x, True


@njit(cache=True, nogil=True)
def add_prior(H, g, est, prior, prior_info):
    """Adds d^T prior_info d, d = prior - est (yaw difference wrapped), to the normal
    equations in place; returns that cost."""
    d = prior - est
    d[2] = (d[2] + np.pi) % (2.0 * np.pi) - np.pi
    cost = 0.0
    for i in range(3):
        for j in range(3):
            w = prior_info[i, j]
            if w != 0.0:
                H[i, j] += w
                g[i] += w * d[j]
                cost += d[i] * w * d[j]
    return cost


@njit(cache=True, nogil=True)
def gn_update(H, g, est, prior, prior_info, max_angle_step):
    """One Gauss-Newton step from normal equations H (3, 3), g (3,) at est (3,), in place:
    the prior's pull added, the rotation clamped to +-max_angle_step, yaw wrapped. Returns
    False (est unchanged) when the map gives no gradient or H (prior included) is singular.
    A gradient in one direction only (points on one straight wall, read along their normals)
    still steps when the prior pins the other."""
    if H[0, 0] == 0.0 and H[1, 1] == 0.0:
        return False
    add_prior(H, g, est, prior, prior_info)
    step, ok = solve3(H, g)
    if not ok:
        return False
    if step[2] > max_angle_step:
        step[2] = max_angle_step
    elif step[2] < -max_angle_step:
        step[2] = -max_angle_step
    est += step
    est[2] = (est[2] + np.pi) % (2.0 * np.pi) - np.pi
    return True


@njit(cache=True, nogil=True)
def gn_iterate(prob, grid_meta, pts_robot, pose, iterations, max_angle_step, prior, prior_info,
               normals=NO_NORMALS):
    """`iterations` Hector Gauss-Newton steps from pose (3,); the rotation of a step is clamped
    to +-max_angle_step (rad). prior: (3,) pose; prior_info: (3, 3) symmetric information
    (cost per m^2 and rad^2; zeros = stock Hector) of a quadratic pull towards the prior,
    d^T prior_info d with d = prior - pose, added to the cost. normals: as in
    gn_normal_equations. Returns (pose (3,), cost at that pose, prior term included)."""
    est = pose.copy()
    for _ in range(iterations):
        H, g, _ = gn_normal_equations(prob, grid_meta, pts_robot, est, normals)
        if not gn_update(H, g, est, prior, prior_info, max_angle_step):
            break
    H, g, cost = gn_normal_equations(prob, grid_meta, pts_robot, est, normals)
    return est, cost + add_prior(H, g, est, prior, prior_info)


def gn_iterate_ref(prob, grid_meta, pts_robot, pose, iterations, max_angle_step, prior=None,
                   prior_info=None, normals=None):
    """Reference of gn_iterate with the numpy normal equations and np.linalg.solve."""
    est = np.array(pose, dtype=np.float64)
    prior = np.zeros(3) if prior is None else np.asarray(prior, dtype=np.float64)
    W = np.zeros((3, 3)) if prior_info is None else np.asarray(prior_info, dtype=np.float64)

    def prior_diff(e):
        d = prior - e
        d[2] = (d[2] + np.pi) % (2.0 * np.pi) - np.pi
        return d

    for _ in range(iterations):
        H, g, _ = gn_normal_equations_ref(prob, grid_meta, pts_robot, est, normals)
        if H[0, 0] == 0.0 and H[1, 1] == 0.0:
            break
        H, g = H + W, g + W @ prior_diff(est)
        try:
            step = np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            break
        step[2] = np.clip(step[2], -max_angle_step, max_angle_step)
        est = est + step
        est[2] = (est[2] + np.pi) % (2.0 * np.pi) - np.pi
    d = prior_diff(est)
    return est, gn_normal_equations_ref(prob, grid_meta, pts_robot, est, normals)[2] + float(d @ W @ d)
