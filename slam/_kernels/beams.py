"""A lidar revolution's beams as points in the robot frame (the compiled core of
slam.preprocess): range limits, optional smoothing over neighbouring beams, the lidar's
mounting offset and the motion de-skew (SE(2) exponential of a constant twist).

scan_points: compiled; scan_points_ref: the same steps in numpy, for tests.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from slam._kernels.smooth import smooth_ranges

__all__ = ["scan_points", "scan_points_ref", "motion_during", "closes_turn"]


@njit(cache=True, nogil=True)
def _beam_point(angle, rng, side, offset, j, twist, time_increment, deskew, out, k):
    """out[k]: the point rng along beam j at `angle` (and `side` to its left) in the robot
    frame at the scan's time, moved by the motion up to the beam's time when deskew."""
    a = angle + offset[2]
    ca, sa = math.cos(a), math.sin(a)
    x = offset[0] + rng * ca - side * sa
    y = offset[1] + rng * sa + side * ca
    if deskew:
        tau = j * time_increment
        vx, vy, w = twist[0], twist[1], twist[2]
        th = w * tau
        c, s = math.cos(th), math.sin(th)
        if abs(w) > 1e-9:
            dx = (vx * s - vy * (1.0 - c)) / w
            dy = (vx * (1.0 - c) + vy * s) / w
        else:
            dx, dy = vx * tau, vy * tau
        x, y = dx + c * x - s * y, dy + s * x + c * y
    out[k, 0] = x
    out[k, 1] = y


@njit(cache=True, nogil=True)
def _select(d, k):
    """d[k] after d is partially ordered in place so that d[:k] <= d[k] <= d[k + 1:] (Hoare's
    selection; a full sort would compile numba's quicksort, seconds of every cold start)."""
    lo, hi = 0, d.shape[0] - 1
    while lo < hi:
        pivot = d[(lo + hi) // 2]
        i, j = lo, hi
        while i <= j:
            while d[i] < pivot:
                i += 1
            while d[j] > pivot:
                j -= 1
            if i <= j:
                d[i], d[j] = d[j], d[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return d[k]


@njit(cache=True, nogil=True)
def _median_step(angles):
    """The median of the steps between consecutive angles (numpy's median: the mean of the
    two middle values of an even count); 0 for fewer than two angles."""
    n = angles.shape[0] - 1
    if n < 1:
        return 0.0
    d = np.empty(n)
    for j in range(n):
        d[j] = angles[j + 1] - angles[j]
    upper = _select(d, n // 2)
    if n % 2:
        return upper
    lower = d[0]
    for j in range(1, n // 2):  # after the selection, the largest of the lower half
        lower = max(lower, d[j])
    return (lower + upper) / 2


@njit(cache=True, nogil=True)
def closes_turn(step, n):
    """True when n beams step (rad) apart close a whole turn: the last neighbours the first."""
    return n > 1 and abs(step * n - 2 * np.pi) < 1e-6


@njit(cache=True, nogil=True)
def scan_points(ranges, angles, offset, range_min, range_max, free_range, smooth_beams,
                smooth_jump, twist, time_increment, deskew):
    """(points (N, 2), misses (M, 2)) in the robot frame of one revolution.

    ranges, angles: (B,) m, rad (lidar frame); offset: (3,) lidar pose in the robot frame.
    A beam is a hit when finite and range_min < r < range_max, a miss (free_range > 0 only)
    when inf or >= range_max; a miss is placed at min(free_range, range_max). smooth_beams
    > 0: each hit replaced by the mean point of its 2k+1 neighbouring hits (smooth_ranges).
    deskew: beam j moved by the twist (3,) (v_x, v_y m/s, w rad/s) over j * time_increment.
    """
    n = ranges.shape[0]
    hit = np.zeros(n, dtype=np.bool_)
    miss = np.zeros(n, dtype=np.bool_)
    r = np.zeros(n)
    n_hit = 0
    n_miss = 0
    for j in range(n):
        v = ranges[j]
        if math.isfinite(v) and range_min < v < range_max:
            hit[j] = True
            r[j] = v
            n_hit += 1
        elif free_range > 0 and (v == math.inf or (math.isfinite(v) and v >= range_max)):
            miss[j] = True
            n_miss += 1
    across = np.zeros(n)
    if smooth_beams > 0 and n_hit > 0:
        # beams are equally spaced over the revolution: the fan's angle step is the beams' step
        step = _median_step(angles)
        along, across = smooth_ranges(r, hit, smooth_beams, smooth_jump, step, closes_turn(step, n))
        for j in range(n):
            if hit[j]:
                r[j] = along[j]
    points = np.empty((n_hit, 2))
    misses = np.empty((n_miss, 2))
    k = m = 0
    far = min(free_range, range_max)
    for j in range(n):
        if hit[j]:
            _beam_point(angles[j], r[j], across[j], offset, j, twist, time_increment, deskew,
                        points, k)
            k += 1
        elif miss[j]:
            _beam_point(angles[j], far, 0.0, offset, j, twist, time_increment, deskew, misses, m)
            m += 1
    return points, misses


def motion_during(twist: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """(K, 3) robot poses at times tau (K,) s relative to tau = 0, for a constant twist (3,)
    (v_x m/s, v_y m/s, w rad/s in the robot frame): the SE(2) exponential."""
    vx, vy, w = (float(v) for v in twist)
    tau = np.asarray(tau, dtype=np.float64)
    th = w * tau
    if abs(w) > 1e-9:
        sin_t, one_cos = np.sin(th), 1.0 - np.cos(th)
        dx = (vx * sin_t - vy * one_cos) / w
        dy = (vx * one_cos + vy * sin_t) / w
    else:
        dx, dy = vx * tau, vy * tau
    return np.stack([dx, dy, th], axis=-1)


def scan_points_ref(ranges, angles, offset, range_min, range_max, free_range, smooth_beams,
                    smooth_jump, twist, time_increment, deskew):
    """scan_points in numpy: masks, smoothing, then all beams at once."""
    r = np.asarray(ranges, dtype=np.float64)
    idx = np.arange(len(r))
    with np.errstate(invalid="ignore"):
        hit = np.isfinite(r) & (r > range_min) & (r < range_max)
        miss = ((np.isposinf(r) | (np.isfinite(r) & (r >= range_max))) & ~hit if free_range > 0
                else np.zeros(len(r), bool))
    across = np.zeros(len(r))
    if smooth_beams > 0 and hit.any():
        step = float(np.median(np.diff(angles))) if len(angles) > 1 else 0.0
        full = len(angles) > 1 and abs(step * len(angles) - 2 * np.pi) < 1e-6
        along, across = smooth_ranges(np.where(hit, r, 0.0), hit, smooth_beams, smooth_jump,
                                      step, full)
        r = np.where(hit, along, r)

    def robot(beams, rng, side):
        a = angles[beams] + offset[2]
        local = np.stack([offset[0] + rng * np.cos(a) - side * np.sin(a),
                          offset[1] + rng * np.sin(a) + side * np.cos(a)], axis=1)
        if not deskew or not len(beams):
            return local.reshape(-1, 2)
        dx, dy, th = motion_during(twist, beams * time_increment).T
        c, s = np.cos(th), np.sin(th)
        return np.stack([dx + c * local[:, 0] - s * local[:, 1],
                         dy + s * local[:, 0] + c * local[:, 1]], axis=1)

    points = robot(idx[hit], r[hit], across[hit])
    misses = robot(idx[miss], np.full(int(miss.sum()), min(free_range, range_max)),
                   np.zeros(int(miss.sum())))
    return points, misses
