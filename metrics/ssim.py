"""SSIM (Wang, Bovik, Sheikh & Simoncelli 2004) between two aligned occupancy maps.

Standard form: Gaussian window sigma = 1.5 cells (truncated at 3.5 sigma, the 11 x 11 window
of the paper), C1 = (0.01 L)^2, C2 = (0.03 L)^2 with L = 1 (probabilities). Unknown cells are
0.5 (neither free nor occupied); the mean is taken over cells known in either map, so the
unknown margins around both maps do not inflate it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from metrics.result import Result

__all__ = ["Similarity", "ssim_map", "ssim"]


@dataclass(frozen=True)
class Similarity(Result):
    """Mean SSIM of the aligned estimate against the truth (see ssim)."""

    ssim: float

_K1, _K2, _SIGMA, _TRUNCATE = 0.01, 0.03, 1.5, 3.5


def ssim_map(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-cell SSIM of two (rows, cols) images with values in [0, 1] (NaN = unknown = 0.5)."""
    a = np.nan_to_num(np.asarray(a, dtype=np.float64), nan=0.5)
    b = np.nan_to_num(np.asarray(b, dtype=np.float64), nan=0.5)
    if a.shape != b.shape:
        raise ValueError(f"ssim: shapes differ {a.shape} vs {b.shape}")
    c1, c2 = _K1 ** 2, _K2 ** 2

    def blur(x):
        return ndimage.gaussian_filter(x, _SIGMA, truncate=_TRUNCATE, mode="reflect")

    mu_a, mu_b = blur(a), blur(b)
    var_a = blur(a * a) - mu_a ** 2
    var_b = blur(b * b) - mu_b ** 2
    cov = blur(a * b) - mu_a * mu_b
    return ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / ((mu_a ** 2 + mu_b ** 2 + c1) * (var_a + var_b + c2))


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Mean SSIM over cells known (not NaN) in a or b; 1.0 for identical maps; NaN if none known."""
    known = ~(np.isnan(np.asarray(a, float)) & np.isnan(np.asarray(b, float)))
    if not known.any():
        return float("nan")
    return float(ssim_map(a, b)[known].mean())
