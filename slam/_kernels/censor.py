"""The shortfall of lidar hits near the maximum range, which the sensor censors: a reading
beyond it returns nothing, so of a surface near it only the shorter readings come back.

With Gaussian range noise sigma, a surface at distance d and the limit R, a reading kept has
the mean of a normal truncated at R: d - sigma * phi(a) / Phi(a), a = (R - d) / sigma. The
surface's distance is read from the other hits within half_window beams and SAME_SURFACE_SIGMAS
of the beam's range (their mean m, the beam's own range if there is none), d solved from
m = d - sigma * phi(a) / Phi(a) by fixed-point iteration (the map d -> m + sigma * phi(a) /
Phi(a) contracts: its slope is one less the truncated normal's variance ratio, between 0 and
1), and the hit's shortfall is sigma * phi(a) / Phi(a) at that d. The neighbours decide, so a
hit's own noise does not choose its correction.

censoring_shortfall: compiled; censoring_shortfall_ref: vectorised numpy, for tests.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.special import ndtr

__all__ = ["SAME_SURFACE_SIGMAS", "FAR_SIGMAS", "censoring_shortfall", "censoring_shortfall_ref"]

SAME_SURFACE_SIGMAS = 4.0   # neighbours farther than this from the beam's range lie on another surface
FAR_SIGMAS = 8.0            # a surface this many sigma inside the limit loses nothing (phi(8) = 5e-15)
_ITERATIONS = 8
_BEYOND_SIGMAS = 1.0        # the solved distance is capped at R + sigma (the readings then say little)


@njit(cache=True, nogil=True)
def _mills(a):
    """phi(a) / Phi(a) of the standard normal, a in [-_BEYOND_SIGMAS, FAR_SIGMAS]."""
    phi = math.exp(-0.5 * a * a) / math.sqrt(2.0 * math.pi)
    return phi / max(0.5 * math.erfc(-a / math.sqrt(2.0)), 1e-12)


@njit(cache=True, nogil=True)
def censoring_shortfall(ranges, range_max, sigma, half_window, circular):
    """ranges: (B,) m, a revolution (inf, NaN, <= 0 or >= range_max: not a hit); sigma: m,
    the range noise near range_max; circular: beam B-1 neighbours beam 0. Returns (B,) m,
    the mean shortfall of each hit's reading (0 for non-hits and hits of surfaces more than
    FAR_SIGMAS inside the limit; all 0 for sigma <= 0, a sensor without noise)."""
    n = ranges.shape[0]
    out = np.zeros(n)
    if not sigma > 0.0:
        return out
    for i in range(n):
        r = ranges[i]
        if not (r > 0.0 and r < range_max):
            continue
        total = 0.0
        count = 0
        for k in range(-half_window, half_window + 1):
            j = i + k
            if k == 0:
                continue
            if circular:
                j = j % n
            elif j < 0 or j >= n:
                continue
            rj = ranges[j]
            if rj > 0.0 and rj < range_max and abs(rj - r) < SAME_SURFACE_SIGMAS * sigma:
                total += rj
                count += 1
        m = total / count if count > 0 else r
        if (range_max - m) / sigma >= FAR_SIGMAS:
            continue
        d = m
        for _ in range(_ITERATIONS):
            a = min(max((range_max - d) / sigma, -_BEYOND_SIGMAS), FAR_SIGMAS)
            d = min(m + sigma * _mills(a), range_max + _BEYOND_SIGMAS * sigma)
        a = min(max((range_max - d) / sigma, -_BEYOND_SIGMAS), FAR_SIGMAS)
        out[i] = sigma * _mills(a)
    return out


def censoring_shortfall_ref(ranges, range_max, sigma, half_window, circular=True):
    """Reference for censoring_shortfall: the same in whole-array numpy."""
    r = np.asarray(ranges, dtype=np.float64)
    n = len(r)
    if not sigma > 0:
        return np.zeros(n)
    hit = (r > 0) & (r < range_max)                              # NaN compares False
    offsets = np.concatenate([np.arange(-half_window, 0), np.arange(1, half_window + 1)])
    j = np.arange(n)[:, None] + offsets[None, :]
    inside = np.ones(j.shape, bool) if circular else (j >= 0) & (j < n)
    j = j % n
    hr = np.where(hit, r, np.nan)
    same = inside & (np.abs(hr[j] - hr[:, None]) < SAME_SURFACE_SIGMAS * sigma)
    count = same.sum(axis=1)
    m = np.where(count > 0, np.where(same, np.nan_to_num(hr[j]), 0.0).sum(axis=1) / np.maximum(count, 1), r)

    def mills(d):
        a = np.clip((range_max - d) / sigma, -_BEYOND_SIGMAS, FAR_SIGMAS)
        return np.exp(-0.5 * a * a) / np.sqrt(2 * np.pi) / np.maximum(ndtr(a), 1e-12)

    d = m.copy()
    for _ in range(_ITERATIONS):
        d = np.minimum(m + sigma * mills(d), range_max + _BEYOND_SIGMAS * sigma)
    near = hit & ((range_max - m) / sigma < FAR_SIGMAS)
    return np.where(near, sigma * mills(d), 0.0)
