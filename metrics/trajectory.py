"""Trajectory error against a true path: ATE and RPE (Sturm et al. 2012, TUM RGB-D benchmark).

ATE: RMSE of position after the least-squares rigid SE(2) alignment of the estimate to the
truth (Umeyama 1991 / Kabsch, no scale), at the estimate's times with the truth linearly
interpolated there. `ate_start_m` is the same RMSE with the frames as given: our SLAMs start at
the true start pose, so this is the error under the start-pose alignment.
RPE: over pairs (i, j) where the true path length from i to j first reaches `segment_m`
(default 1 m), the error of the estimated relative motion against the true one, translation
(m) and rotation (rad), mean and RMSE. RPE needs no alignment.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from metrics.result import Result
from sim.logs.tum import MAX_COORD_M, MAX_TIME_S
from slam.pose import compose, interpolate_poses, relative, wrap_angle
from worlds.yamlio import InputError

__all__ = ["TrajectoryContext", "TrajectoryError", "rigid_fit_2d", "ate_rpe",
           "trajectory_error"]


@dataclass(frozen=True)
class TrajectoryContext:
    """What a trajectory metric reads: the estimate's times (N,) s and poses (N, 3), the true
    ones (M,) and (M, 3), and the RPE segment length (m)."""

    times: np.ndarray
    poses: np.ndarray
    gt_t: np.ndarray
    gt_poses: np.ndarray
    segment_m: float = 1.0


@dataclass(frozen=True)
class TrajectoryError(Result):
    """ATE and RPE of one trajectory (see trajectory_error); NaN where undefined."""

    ate_m: float
    ate_start_m: float
    ate_yaw_rad: float
    ate_align: dict
    n_poses: int
    segment_m: float
    rpe_pairs: int
    rpe_trans_m: float
    rpe_rot_rad: float
    rpe_trans_rmse_m: float
    rpe_rot_rmse_rad: float
    note: str | None = None


def rigid_fit_2d(src: np.ndarray, dst: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Least-squares rigid transform (no scale) taking src onto dst (2D Kabsch/Umeyama).

    src, dst: (N, 2) corresponding points (m), N >= 1; weights: (N,) >= 0 or None.
    Returns the pose (3,) x, y, yaw with transform_points(pose, src) ~ dst.
    """
    src = np.asarray(src, dtype=np.float64).reshape(-1, 2)
    dst = np.asarray(dst, dtype=np.float64).reshape(-1, 2)
    w = np.ones(len(src)) if weights is None else np.asarray(weights, dtype=np.float64)
    wsum = w.sum()
    if len(src) == 0 or wsum <= 0:
        return np.zeros(3)
    cs = (w[:, None] * src).sum(0) / wsum
    cd = (w[:, None] * dst).sum(0) / wsum
    a = src - cs
    b = dst - cd
    # the 2D cross-covariance reduces to one angle: atan2(sum w a x b, sum w a . b)
    sxy = np.sum(w * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    sxx = np.sum(w * (a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
    yaw = np.arctan2(sxy, sxx)
    c, s = np.cos(yaw), np.sin(yaw)
    t = cd - np.array([c * cs[0] - s * cs[1], s * cs[0] + c * cs[1]])
    return np.array([t[0], t[1], wrap_angle(yaw)])


def _rmse(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(v)))) if len(v) else float("nan")


def _check(t: np.ndarray, poses: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(N,) times and (N, 3) poses sorted by time; InputError naming `name` and the first bad
    pose when the shapes differ, a value is not finite or beyond sim.logs.tum's bounds
    (|t| <= MAX_TIME_S, |x|, |y| <= MAX_COORD_M: beyond them the alignment's squares
    overflow), or a time repeats."""
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    poses = np.asarray(poses, dtype=np.float64)
    if poses.ndim != 2 or poses.shape[1] != 3 or len(poses) != len(t):
        raise InputError(f"{name}: expected (N,) times and (N, 3) poses, got {t.shape} and {poses.shape}")
    if len(t) == 0:
        raise InputError(f"{name}: empty trajectory")
    values = np.column_stack([t, poses])
    bad = ~np.isfinite(values)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        field = ("t", "x", "y", "yaw")[j]
        raise InputError(f"{name}: pose {i}: non-finite {field}: {values[i, j]}")
    limit = np.array([MAX_TIME_S, MAX_COORD_M, MAX_COORD_M, np.inf])
    beyond = np.abs(values) > limit
    if beyond.any():
        i, j = np.argwhere(beyond)[0]
        raise InputError(f"{name}: pose {i}: {('t', 'x', 'y')[j]}: {values[i, j]:g} is beyond "
                         f"+-{limit[j]:g}")
    order = np.argsort(t, kind="stable")
    t, poses = t[order], poses[order]
    if np.any(np.diff(t) <= 0):
        raise InputError(f"{name}: repeated timestamps")
    return t, poses


def trajectory_error(est_t: np.ndarray, est_poses: np.ndarray, gt_t: np.ndarray,
                     gt_poses: np.ndarray, segment_m: float = 1.0) -> dict:
    """ATE and RPE of an estimated trajectory against the true one.

    est_t: (N,) s, est_poses: (N, 3) x, y (m), yaw (rad); gt_t: (M,) s, gt_poses: (M, 3).
    Estimated poses outside the true time span are dropped (no extrapolation).
    Returns a dict: ate_m (RMSE after SE(2) alignment), ate_start_m (frames as given),
    ate_yaw_rad (RMSE of heading after alignment), ate_align {"x","y","yaw"} (estimate ->
    truth), rpe_trans_m / rpe_rot_rad (mean over `segment_m` segments), rpe_trans_rmse_m,
    rpe_rot_rmse_rad, rpe_pairs, n_poses, segment_m and, when something is undefined, `note`.
    Raises InputError when fewer than 2 estimated poses fall inside the true time span.
    """
    return ate_rpe(est_t, est_poses, gt_t, gt_poses, segment_m).as_dict()


def ate_rpe(est_t: np.ndarray, est_poses: np.ndarray, gt_t: np.ndarray, gt_poses: np.ndarray,
            segment_m: float = 1.0) -> TrajectoryError:
    """trajectory_error as a TrajectoryError (same arguments, same values)."""
    est_t, est_poses = _check(est_t, est_poses, "estimated trajectory")
    gt_t, gt_poses = _check(gt_t, gt_poses, "true trajectory")
    inside = (est_t >= gt_t[0]) & (est_t <= gt_t[-1])
    if inside.sum() < 2:
        raise InputError(f"estimated trajectory: {int(inside.sum())} poses inside the true time span "
                         f"[{gt_t[0]:.3f}, {gt_t[-1]:.3f}] s; need at least 2 (time bases differ?)")
    est_t, est = est_t[inside], est_poses[inside]
    gt = interpolate_poses(est_t, gt_t, gt_poses)

    ate_start = _rmse(np.linalg.norm(est[:, :2] - gt[:, :2], axis=1))
    fit = rigid_fit_2d(est[:, :2], gt[:, :2])
    aligned = compose(fit, est)
    ate = _rmse(np.linalg.norm(aligned[:, :2] - gt[:, :2], axis=1))
    ate_yaw = _rmse(wrap_angle(aligned[:, 2] - gt[:, 2]))

    # segment pairs by true path length: j is the first pose at least segment_m past i
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(gt[:, :2], axis=0), axis=1))])
    # (1e-9 m: a segment summed from many steps may fall short of segment_m by rounding)
    j = np.searchsorted(dist, dist + segment_m - 1e-9, side="left")
    i = np.nonzero(j < len(dist))[0]
    j = j[i]
    head = (ate, ate_start, ate_yaw, {"x": float(fit[0]), "y": float(fit[1]), "yaw": float(fit[2])},
            int(len(est_t)), float(segment_m), int(len(i)))
    if len(i):
        err = relative(relative(gt[i], gt[j]), relative(est[i], est[j]))
        et = np.linalg.norm(err[:, :2], axis=1)
        er = np.abs(err[:, 2])
        return TrajectoryError(*head, float(et.mean()), float(er.mean()), _rmse(et), _rmse(er))
    nan = float("nan")
    return TrajectoryError(*head, nan, nan, nan, nan,
                           note=f"true path shorter than {segment_m} m: RPE undefined (NaN)")
