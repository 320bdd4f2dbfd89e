"""Log-odds to occupancy probability over a whole grid, the matchers' view of a map.

logodds_to_prob: compiled, one pass; logodds_to_prob_ref: numpy, for tests. The local SLAM
of `graph` and every level of `gn` convert their grid after each insertion, so the numpy
version's four full-grid passes and temporaries were a visible share of a run.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["logodds_to_prob", "logodds_to_prob_ref"]


@njit(cache=True, nogil=True)
def logodds_to_prob(logodds, unknown):
    """(rows, cols) float64 log-odds, NaN = never touched -> (rows, cols) float64
    probabilities 1 / (1 + exp(-l)); never-touched cells get `unknown`."""
    rows, cols = logodds.shape
    out = np.empty((rows, cols))
    for r in range(rows):
        for c in range(cols):
            v = logodds[r, c]
            if v != v:
                out[r, c] = unknown
            else:
                out[r, c] = 1.0 / (1.0 + math.exp(-v))
    return out


def logodds_to_prob_ref(logodds: np.ndarray, unknown: float) -> np.ndarray:
    """Reference: the logistic function with numpy, unknown cells filled afterwards."""
    p = 1.0 / (1.0 + np.exp(-np.nan_to_num(logodds, nan=0.0)))
    p[np.isnan(logodds)] = unknown
    return p
