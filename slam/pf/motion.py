"""Particle-filter pieces of the Gmapping family: odometry motion sampling, the motion prior,
weight normalisation, effective sample size and low-variance resampling.

Motion model: Gmapping's MotionModel::drawFromMotion. The odometry increment (dx, dy, dyaw),
in the robot frame at the previous pose, is perturbed by zero-mean Gaussians with standard
deviations
    x:   srr |dx| + str |dyaw| + 0.3 srr |dy|
    y:   srr |dy| + str |dyaw| + 0.3 srr |dx|
    yaw: stt |dyaw| + srt sqrt(dx^2 + dy^2)
and composed onto each particle's pose. (srr: translation error per translation, srt:
rotation per translation, str: translation per rotation, stt: rotation per rotation.)
"""
from __future__ import annotations

import numpy as np

from slam.pose import compose, wrap_angle

__all__ = ["motion_std", "sample_motion", "normalized_weights", "effective_sample_size",
           "systematic_resample"]


def motion_std(delta: np.ndarray, srr: float, srt: float, str_: float, stt: float) -> np.ndarray:
    """(..., 3) standard deviations of the perturbation of odometry increments (..., 3)."""
    delta = np.asarray(delta, dtype=np.float64)
    ax, ay, aa = np.abs(delta[..., 0]), np.abs(delta[..., 1]), np.abs(delta[..., 2])
    sxy = 0.3 * srr
    return np.stack([srr * ax + str_ * aa + sxy * ay,
                     srr * ay + str_ * aa + sxy * ax,
                     stt * aa + srt * np.hypot(ax, ay)], axis=-1)


def sample_motion(poses: np.ndarray, delta: np.ndarray, srr: float, srt: float, str_: float,
                  stt: float, rng: np.random.Generator) -> np.ndarray:
    """Move each particle (N, 3) by the odometry increment delta (3,) with sampled noise."""
    poses = np.asarray(poses, dtype=np.float64)
    std = motion_std(delta, srr, srt, str_, stt)
    noisy = np.asarray(delta, dtype=np.float64) + rng.standard_normal((len(poses), 3)) * std
    noisy[:, 2] = wrap_angle(noisy[:, 2])
    return compose(poses, noisy)


def normalized_weights(log_w: np.ndarray, ogain: float) -> np.ndarray:
    """(N,) weights summing to 1 from log weights, smoothed as Gmapping's normalize():
    w_i ~ exp((log_w_i - max) / (ogain * N)); ogain 1/N gives the plain posterior weights."""
    log_w = np.asarray(log_w, dtype=np.float64)
    gain = 1.0 / (ogain * len(log_w))
    w = np.exp(gain * (log_w - log_w.max()))
    return w / w.sum()


def effective_sample_size(weights: np.ndarray) -> float:
    """Neff = 1 / sum(w_i^2) of normalised weights (N,): N when uniform, 1 when one-hot."""
    w = np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    return float(1.0 / np.sum(w * w))


def systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Low-variance (systematic) resampling: (N,) ancestor indices, sorted.

    One uniform offset u in [0, 1/N); particle i is drawn once for every point
    u + k / N that falls into its slice of the cumulative weights, so it gets
    floor(N w_i) or ceil(N w_i) copies.
    """
    w = np.asarray(weights, dtype=np.float64)
    n = len(w)
    cum = np.cumsum(w / w.sum())
    cum[-1] = 1.0
    points = (rng.random() + np.arange(n)) / n
    return np.searchsorted(cum, points, side="right").astype(np.int64)
