"""Alignment of an estimated map to the true map: an SE(2) transform estimate -> truth.

Modes:
- `none`: the identity (the frames are taken as equal).
- `start`: `initial` as given (for our SLAMs, which start at the true start pose, the identity).
- `icp`: trimmed point-to-point ICP (Besl & McKay 1992) on occupied-cell centres, started from
  `initial` (identity when None). Correspondences come from a k-d tree over the true cells and
  are rejected beyond a distance that shrinks geometrically over the iterations (from
  `icp_start_cells` to `icp_final_cells`), so extra (false) walls of the estimate do not pull.
  It ends with point-to-line ICP (`refine_point_to_line`), which fixes the last tenth of a
  degree that point-to-point ICP, snapping cells onto cells, gets wrong.
- `global`: no prior. For every rotation on a `rot_step_deg` grid over 360 degrees, the rotated
  estimate's cells are binned on a coarse grid and cross-correlated (FFT) with a smooth image
  of the truth, exp(-d^2 / 2 h^2) of the distance d to the nearest true cell; the best
  translations of the best-scoring rotations are refined by ICP and the candidate with the most
  inliers wins. Ties between symmetric solutions go to the first found.
- `auto`: `icp` when `initial` is known, else `global`.
Maps of any resolution and size are aligned as point sets in metres, so nothing is rejected.

The surface form scores cells against the exact surfaces, so it takes that pose one step
further (`refine_to_surfaces`): a robust least-squares fit of the estimate's occupied cell
squares onto the surfaces, in which a square the surface passes through costs nothing. Cell
centres sit up to half a cell from the surface they hold, so ICP on centres stops where the
quantisation balances, a few mrad and millimetres off a map that is merely turned; the squares
carry no such bias: a map that is the truth moved rigidly scores as the truth does.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft

from metrics.result import Result
from metrics.trajectory import rigid_fit_2d
from metrics.truth import PreparedTruth
from slam.pose import compose, transform_points, wrap_angle
from worlds.yamlio import InputError

__all__ = ["AlignConfig", "Alignment", "MapAlignment", "MODES", "align_points", "icp",
           "global_candidates", "refine_to_surfaces"]

MODES = ("auto", "none", "start", "icp", "global")


@dataclass(frozen=True)
class AlignConfig:
    """Alignment parameters; distances in true-map cells."""

    rot_step_deg: float = 2.0         # rotation grid of the global search (ICP fixes +-1 deg)
    coarse_cells: float = 3.0         # global search translation cell, in true cells
    candidates: int = 4               # rotations refined by ICP in the global search
    max_coarse: int = 200             # at most this many search bins across the true map
    icp_max_iter: int = 80
    icp_start_cells: float = 12.0     # correspondence cut-off at the first iteration
    icp_final_cells: float = 3.0      # ... shrinking to this
    icp_shrink: float = 0.8           # factor per iteration
    icp_tol_cells: float = 0.005      # converged when a step moves every point less than this
    inlier_cells: float = 1.5         # a point this close to a true cell counts as an inlier
    point_to_line: bool = True        # finish `icp` and `global` with point-to-line ICP
    line_cut_cells: float = 2.0       # its correspondence cut-off
    line_max_iter: int = 30
    surface_cut_cells: float = 2.0    # refine_to_surfaces: pairs a cell centre with a surface
    surface_sigma_cells: float = 0.1  # this near; Welsch scale of the square's distance to it
    surface_max_iter: int = 30


@dataclass(frozen=True)
class Alignment:
    """pose: (3,) x, y (m), yaw (rad) taking estimate world coordinates to truth world
    coordinates; mode: the mode actually used; inlier_fraction: share of estimated cells within
    `inlier_cells` of a true cell after alignment; rms_m: RMS distance of those inliers."""

    pose: np.ndarray
    mode: str
    inlier_fraction: float
    rms_m: float
    iterations: int = 0

    def as_dict(self) -> dict:
        return {"x": float(self.pose[0]), "y": float(self.pose[1]), "yaw": float(self.pose[2])}


@dataclass(frozen=True)
class MapAlignment(Result):
    """The alignment a map score used ({"x", "y", "yaw"}, mode, inlier fraction, RMS of the
    inliers in m) and the occupied cells and resolution (m) it worked on."""

    align: dict
    align_mode: str
    align_inlier_fraction: float
    align_rms_m: float
    est_occupied: int
    true_occupied: int
    resolution: float


def _fitness(pts: np.ndarray, truth: PreparedTruth, pose: np.ndarray, cut: float) -> tuple[float, float]:
    d, _ = truth.tree.query(transform_points(pose, pts), distance_upper_bound=cut)
    inl = np.isfinite(d)
    if not inl.any():
        return 0.0, float("nan")
    return float(inl.mean()), float(np.sqrt(np.mean(d[inl] ** 2)))


def _matches(pts, truth, pose, cut):
    """(moved points, index of their nearest true cell) for those within `cut`; None if < 3."""
    moved = transform_points(pose, pts)
    d, idx = truth.tree.query(moved, distance_upper_bound=cut)
    inl = np.isfinite(d)
    return (moved[inl], idx[inl]) if inl.sum() >= 3 else None


def _icp_loop(pts, truth, pose, cut, final, radius, cfg):
    it = 0
    for it in range(1, cfg.icp_max_iter + 1):
        m = _matches(pts, truth, pose, cut)
        if m is None:
            break
        step = rigid_fit_2d(m[0], truth.points[m[1]])
        pose = compose(step, pose)
        shift = np.hypot(step[0], step[1]) + abs(step[2]) * radius
        at_final = cut <= final
        cut = max(final, cut * cfg.icp_shrink)
        if at_final and shift < cfg.icp_tol_cells * truth.resolution:
            break
    return pose, it


def _cost(pts, truth, pose, cut):
    d, _ = truth.tree.query(transform_points(pose, pts), distance_upper_bound=cut)
    return float(np.mean(np.minimum(d, cut) ** 2))


# half-cell moves tried after convergence (x, y in cells, turn in half-cell arcs), see icp()
_HALF_STEPS = [(dx, dy, da) for dx in (-0.5, 0.0, 0.5) for dy in (-0.5, 0.0, 0.5)
               for da in (-1, 0, 1) if dx or dy or da]


def _half_cell_moves(pts: np.ndarray, pose: np.ndarray, res: float) -> list[np.ndarray]:
    """Poses moved by half a cell and/or turned (about the centroid) by half a cell's arc."""
    moved = transform_points(pose, pts)
    c = moved.mean(0)
    rms_radius = max(float(np.sqrt(np.mean(np.sum((moved - c) ** 2, 1)))), res)
    turn = 0.5 * res / rms_radius
    out = []
    for dx, dy, da in _HALF_STEPS:
        a = da * turn
        ca, sa = np.cos(a), np.sin(a)
        # rotate by a about c, then shift: x -> R (x - c) + c + d
        t = c - np.array([ca * c[0] - sa * c[1], sa * c[0] + ca * c[1]]) + np.array([dx, dy]) * res
        out.append(compose(np.array([t[0], t[1], a]), pose))
    return out


def icp(pts: np.ndarray, truth: PreparedTruth, initial: np.ndarray,
        cfg: AlignConfig = AlignConfig(), polish: bool = True) -> tuple[np.ndarray, int]:
    """Trimmed point-to-point ICP of estimated cell centres onto the true ones.

    pts: (N, 2) estimate occupied-cell centres, estimate world m; initial: (3,) start transform.
    Returns (pose (3,), iterations used).
    On grids, point-to-point ICP has balanced fixed points half a cell off (each point halfway
    between two true cells). After convergence the 8 half-cell moves are tried; when one lowers
    the truncated squared distance, ICP restarts from there (at most 3 times).
    """
    res = truth.resolution
    pose = np.asarray(initial, dtype=np.float64).copy()
    if len(pts) < 3:
        return pose, 0
    radius = max(float(np.max(np.linalg.norm(pts - pts.mean(0), axis=1))), res)
    final = cfg.icp_final_cells * res
    pose, total = _icp_loop(pts, truth, pose, cfg.icp_start_cells * res, final, radius, cfg)
    if not polish:
        return pose, total
    pose, total = polish_half_cells(pts, truth, pose, cfg, total)
    if cfg.point_to_line:
        pose, it = refine_point_to_line(pts, truth, pose, cfg)
        total += it
    return pose, total


def polish_half_cells(pts: np.ndarray, truth: PreparedTruth, pose: np.ndarray,
                      cfg: AlignConfig = AlignConfig(), total: int = 0) -> tuple[np.ndarray, int]:
    """The half-cell escape of icp(): pose (3,) -> (better pose, iterations so far)."""
    res = truth.resolution
    final = cfg.icp_final_cells * res
    radius = max(float(np.max(np.linalg.norm(pts - pts.mean(0), axis=1))), res)
    for _ in range(3):
        cost = _cost(pts, truth, pose, final)
        trials = _half_cell_moves(pts, pose, res)
        costs = [_cost(pts, truth, p, final) for p in trials]
        k = int(np.argmin(costs))
        if not costs[k] < 0.98 * cost:
            break
        cand, it = _icp_loop(pts, truth, trials[k], final, final, radius, cfg)
        total += it
        if not _cost(pts, truth, cand, final) < cost:
            break
        pose = cand
    return pose, total


def refine_point_to_line(pts: np.ndarray, truth: PreparedTruth, pose: np.ndarray,
                         cfg: AlignConfig = AlignConfig()) -> tuple[np.ndarray, int]:
    """Point-to-line ICP (Chen & Medioni 1992) from `pose`: minimise the weighted squared
    distances of the estimated cell centres to the local wall lines of their nearest true cells.

    Point-to-point ICP snaps cells onto the true cells, so it settles where the estimate's
    cells best match the truth's quantisation, about 0.1 degree and 1 cm off for an estimate
    on a finer grid (tests/metrics/test_align.py). Distances to lines average that out.
    Lines come from PreparedTruth.normals(), weighted by how straight the wall is there;
    residuals get a Cauchy weight with a half-cell scale against stray cells.
    Returns (pose (3,), iterations).
    """
    res = truth.resolution
    normals, straight = truth.normals()
    pose = np.asarray(pose, dtype=np.float64).copy()
    cut = cfg.line_cut_cells * res
    it = 0
    for it in range(1, cfg.line_max_iter + 1):
        m = _matches(pts, truth, pose, cut)
        if m is None:
            break
        p, idx = m
        q, n, w = truth.points[idx], normals[idx], straight[idx]
        c = p.mean(0)
        r = np.sum(n * (p - q), axis=1)
        w = w / (1.0 + (r / (0.5 * res)) ** 2)
        # step about the centroid: p' = R(a) (p - c) + c + t, linearised at a = 0
        arm = n[:, 1] * (p[:, 0] - c[0]) - n[:, 0] * (p[:, 1] - c[1])
        jac = np.column_stack([n[:, 0], n[:, 1], arm])
        h = jac.T @ (w[:, None] * jac)
        if np.linalg.cond(h) > 1e12:
            break  # a single straight wall: the position along it is not defined
        tx, ty, a = np.linalg.solve(h, -(jac.T @ (w * r)))
        ca, sa = np.cos(a), np.sin(a)
        step = np.array([c[0] - (ca * c[0] - sa * c[1]) + tx, c[1] - (sa * c[0] + ca * c[1]) + ty, a])
        pose = compose(step, pose)
        radius = float(np.sqrt(np.mean(np.sum((p - c) ** 2, axis=1))))
        if np.hypot(tx, ty) + abs(a) * radius < cfg.icp_tol_cells * res:
            break
    return pose, it


def global_candidates(pts: np.ndarray, truth: PreparedTruth,
                      cfg: AlignConfig = AlignConfig()) -> list[np.ndarray]:
    """Coarse exhaustive search: the best pose (3,) of each of the `cfg.candidates` best rotations.

    pts: (N, 2) estimate occupied-cell centres (m). Rotations are local maxima of the
    correlation score over the rotation grid, best first.
    """
    span = float(np.max(truth.points.max(0) - truth.points.min(0)))
    # large maps (real buildings): at most ~cfg.max_coarse bins across, to bound FFT cost
    h = max(cfg.coarse_cells * truth.resolution, span / cfg.max_coarse)
    score_img, lo = truth.coarse_score(h)
    ht, wt = score_img.shape
    centre = pts.mean(0)
    q0 = pts - centre
    reach = float(np.max(np.linalg.norm(q0, axis=1))) + h
    k = int(np.ceil(2 * reach / h)) + 1
    shape = (sfft.next_fast_len(ht + k - 1, real=True), sfft.next_fast_len(wt + k - 1, real=True))
    spec = truth.spectrum(h, shape)
    angles = np.deg2rad(np.arange(0.0, 360.0, cfg.rot_step_deg))
    best = np.empty(len(angles))
    shifts = np.empty((len(angles), 2), dtype=np.int64)
    batch = 24  # rotations per FFT call: fewer Python round trips, bounded memory
    for b0 in range(0, len(angles), batch):
        a = angles[b0:b0 + batch]
        c, s = np.cos(a)[:, None], np.sin(a)[:, None]
        qx = c * q0[:, 0] - s * q0[:, 1]
        qy = s * q0[:, 0] + c * q0[:, 1]
        cx = np.clip(np.floor((qx + reach) / h).astype(np.int64), 0, k - 1)
        cy = np.clip(np.floor((qy + reach) / h).astype(np.int64), 0, k - 1)
        flat_idx = (np.arange(len(a))[:, None] * k + cy) * k + cx
        img = np.bincount(flat_idx.ravel(), minlength=len(a) * k * k).reshape(len(a), k, k)
        # full cross-correlation: corr[m] = sum_x img[x] score[x + m - (k - 1)]
        corr = sfft.irfft2(spec * sfft.rfft2(img[:, ::-1, ::-1], s=shape), s=shape)
        flat = corr.reshape(len(a), -1).argmax(axis=1)
        best[b0:b0 + len(a)] = corr.reshape(len(a), -1)[np.arange(len(a)), flat]
        shifts[b0:b0 + len(a)] = np.stack(np.unravel_index(flat, shape), axis=1)
    # local maxima over the circular rotation grid, best first
    n = len(angles)
    peaks = [i for i in range(n) if best[i] >= best[(i - 1) % n] and best[i] >= best[(i + 1) % n]]
    peaks.sort(key=lambda i: -best[i])
    out = []
    for i in peaks[: cfg.candidates]:
        a = angles[i]
        sr, sc = shifts[i] - (k - 1)
        # canvas cell (r, c) lands on coarse truth cell (r + sr, c + sc): t = lo + s h + reach
        t = lo + np.array([sc, sr]) * h + reach
        c, s = np.cos(a), np.sin(a)
        rc = np.array([c * centre[0] - s * centre[1], s * centre[0] + c * centre[1]])
        out.append(np.array([t[0] - rc[0], t[1] - rc[1], wrap_angle(a)]))
    return out


def align_points(pts: np.ndarray, truth: PreparedTruth, mode: str = "auto",
                 initial=(0.0, 0.0, 0.0), cfg: AlignConfig = AlignConfig()) -> Alignment:
    """Transform (estimate -> truth) of estimated occupied cell centres `pts` (N, 2) world m.

    mode: one of MODES; initial: (3,) prior transform or None (unknown). With fewer than 3
    points the prior (or identity) is returned unrefined.
    """
    if mode not in MODES:
        raise InputError(f"align: unknown mode {mode!r} (choose from {', '.join(MODES)})")
    prior = None if initial is None else np.asarray(initial, dtype=np.float64).reshape(3)
    if mode == "auto":
        mode = "icp" if prior is not None else "global"
    if mode == "start" and prior is None:
        raise InputError("align: mode 'start' needs a start pose (initial)")
    cut = cfg.inlier_cells * truth.resolution
    if mode == "none" or len(pts) < 3:
        pose = np.zeros(3) if (mode == "none" or prior is None) else prior
        return Alignment(pose, mode, *_fitness(pts, truth, pose, cut))
    if mode == "start":
        return Alignment(prior.copy(), mode, *_fitness(pts, truth, prior, cut))
    if mode == "icp":
        pose, it = icp(pts, truth, np.zeros(3) if prior is None else prior, cfg)
        return Alignment(pose, mode, *_fitness(pts, truth, pose, cut), iterations=it)
    # the half-cell polish (the costly part of ICP) only for the winner
    best = None
    for cand in global_candidates(pts, truth, cfg):
        pose, it = icp(pts, truth, cand, cfg, polish=False)
        frac, rms = _fitness(pts, truth, pose, cut)
        key = (round(frac, 6), -rms if np.isfinite(rms) else -np.inf)
        if best is None or key > best[0]:
            best = (key, pose, it)
    pose, it = polish_half_cells(pts, truth, best[1], cfg, best[2])
    if cfg.point_to_line:
        pose, more = refine_point_to_line(pts, truth, pose, cfg)
        it += more
    return Alignment(pose, "global", *_fitness(pts, truth, pose, cut), iterations=it)


def _surface_samples(segments: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points at most `step` apart along each segment (S, 4) and the segment index of each."""
    length = np.hypot(segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1])
    n = np.maximum(np.ceil(length / step).astype(np.int64), 1) + 1
    seg = np.repeat(np.arange(len(segments)), n)
    t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n - 1, n)
    a, b = segments[seg, :2], segments[seg, 2:]
    return a + t[:, None] * (b - a), seg


def refine_to_surfaces(pts: np.ndarray, segments: np.ndarray, pose: np.ndarray,
                       resolution: float, cfg: AlignConfig = AlignConfig(),
                       cell_yaw: float = 0.0) -> tuple[np.ndarray, int]:
    """The surface form's alignment: `pose` (3,) (estimate -> truth, e.g. ICP's) refined so
    that the estimate's occupied cells touch the true surfaces.

    pts: (N, 2) occupied cell centres in the estimate's frame (m), cells `resolution` m square
    with their sides turned by `cell_yaw` there (the estimate grid's origin yaw); segments:
    (S, 4) x0, y0, x1, y1 of the surfaces, truth frame (m).
    Each centre is paired with its nearest surface point within `surface_cut_cells`; its
    residual r is how far the cell's square stays from that point (0 when the surface passes
    through the square). The cost is Welsch's 1 - exp(-r^2 / 2 sigma^2), sigma =
    `surface_sigma_cells` (a tenth of a cell): a square a few sigma from its surface, or a
    centre with no surface within the cut, is a wrong cell (a wall drawn a cell off, clutter)
    that costs 1 wherever the map goes, so wrong cells cannot drag the map off the right ones.
    Gauss-Newton steps about the centroid, each kept only if it lowers the total cost.
    Returns (pose (3,), iterations).
    """
    pose = np.asarray(pose, dtype=np.float64).reshape(3).copy()
    segments = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    if len(pts) < 3 or len(segments) == 0:
        return pose, 0
    from scipy.spatial import cKDTree
    samples, seg_of = _surface_samples(segments, 0.1 * resolution)
    tree = cKDTree(samples)
    a = segments[:, :2]
    ab = segments[:, 2:] - a
    ab2 = np.maximum(np.sum(ab * ab, axis=1), 1e-18)
    half = 0.5 * resolution
    cut = cfg.surface_cut_cells * resolution
    sigma = cfg.surface_sigma_cells * resolution

    def residuals(p_pose):
        moved = transform_points(p_pose, pts)
        _, k = tree.query(moved, distance_upper_bound=cut + 0.1 * resolution)
        near = k < len(samples)
        moved = moved[near]
        s = seg_of[k[near]]
        t = np.clip(np.sum((moved - a[s]) * ab[s], axis=1) / ab2[s], 0.0, 1.0)
        e = moved - (a[s] + t[:, None] * ab[s])
        dist = np.hypot(e[:, 0], e[:, 1])
        u = e / np.maximum(dist, 1e-12)[:, None]
        # the square's reach towards the surface: u in the cells' axes
        c, sn = np.cos(p_pose[2] + cell_yaw), np.sin(p_pose[2] + cell_yaw)
        reach = half * (np.abs(c * u[:, 0] + sn * u[:, 1]) + np.abs(-sn * u[:, 0] + c * u[:, 1]))
        r = np.maximum(dist - reach, 0.0)
        inl = dist <= cut
        return moved[inl], u[inl], r[inl], len(pts) - int(inl.sum())

    def evaluate(p_pose):
        res = residuals(p_pose)
        return float(np.sum(-np.expm1(-0.5 * (res[2] / sigma) ** 2)) + res[3]), res

    current, res = evaluate(pose)
    it = 0
    for it in range(1, cfg.surface_max_iter + 1):
        p, u, r, _ = res
        w = np.exp(-0.5 * (r / sigma) ** 2)
        on = (r > 0.0) & (w > 1e-6)
        if on.sum() < 3:
            break
        p, u, r, w = p[on], u[on], r[on], w[on]
        c = p.mean(0)
        # p' = R(a) (p - c) + c + t, linearised at a = 0: dr = u . (t + a perp(p - c))
        arm = u[:, 1] * (p[:, 0] - c[0]) - u[:, 0] * (p[:, 1] - c[1])
        jac = np.column_stack([u[:, 0], u[:, 1], arm])
        h = jac.T @ (w[:, None] * jac)
        # a wall seen alone leaves the motion along it free: the damping keeps that step at 0
        h[np.diag_indices(3)] += 1e-9 * (1.0 + np.trace(h))
        step = np.linalg.solve(h, -(jac.T @ (w * r)))
        radius = float(np.sqrt(np.mean(np.sum((p - c) ** 2, axis=1))))
        accepted = False
        for _ in range(6):
            tx, ty, ang = step
            ca, sa = np.cos(ang), np.sin(ang)
            cand = compose(np.array([c[0] - (ca * c[0] - sa * c[1]) + tx,
                                     c[1] - (sa * c[0] + ca * c[1]) + ty, ang]), pose)
            new, new_res = evaluate(cand)
            if new < current:
                pose, current, res, accepted = cand, new, new_res, True
                break
            step = 0.5 * step
        if not accepted or np.hypot(step[0], step[1]) + abs(step[2]) * radius < cfg.icp_tol_cells * resolution:
            break
    return pose, it
