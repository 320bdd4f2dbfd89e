"""The range noise model of a lidar by range band, as a log's meta records it (noise.lidar):
the simulator draws with it (sim.noise.LidarNoise) and the SLAMs' output map weighs hits by it
(slam.range_noise.RangeNoise).

sigma(r) = sqrt(stddev^2 + (accuracy(r) / accuracy_sigmas)^2); accuracy(r), the datasheet's
+- accuracy at range r, is accuracy + ratio * r of the first band [up_to, accuracy, ratio]
with r < up_to, the last band past them all.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["MAX_BANDS", "check_bands", "accuracy_bands", "range_sigma"]

MAX_BANDS = 8


def check_bands(bands) -> tuple[tuple[float, float, float], ...]:
    """`bands` as a tuple of (up_to, accuracy, ratio) float triples; ValueError unless each is
    finite and >= 0, up_to increasing, and there are at most MAX_BANDS."""
    out = tuple(tuple(float(v) for v in b) for b in bands)
    if len(out) > MAX_BANDS:
        raise ValueError(f"bands: at most {MAX_BANDS} range bands, got {len(out)}")
    for i, b in enumerate(out):
        if len(b) != 3 or not all(math.isfinite(v) and v >= 0 for v in b):
            raise ValueError(f"bands[{i}]: expected [up_to, accuracy, ratio], finite numbers >= 0, "
                             f"got {list(b)}")
        if i and b[0] <= out[i - 1][0]:
            raise ValueError(f"bands[{i}]: up_to {b[0]} is not above the previous band's {out[i - 1][0]}")
    return out


def accuracy_bands(bands, near_accuracy: float, far_accuracy_ratio: float,
                   split: float) -> tuple[tuple[float, float, float], ...]:
    """`bands` if given, else the two bands of the near/far form."""
    if bands:
        return tuple(bands)
    return ((float(split), float(near_accuracy), 0.0), (float(split), 0.0, float(far_accuracy_ratio)))


def range_sigma(r, stddev: float, bands, accuracy_sigmas: float) -> np.ndarray:
    """sqrt(stddev^2 + (accuracy(r) / accuracy_sigmas)^2) at range(s) r (m; inf reads as 0)."""
    r = np.asarray(r, dtype=np.float64)
    rf = np.where(np.isfinite(r), r, 0.0)
    acc = np.full(rf.shape, bands[-1][1]) + bands[-1][2] * rf
    for up_to, a, ratio in reversed(bands[:-1]):
        acc = np.where(rf < up_to, a + ratio * rf, acc)
    return np.sqrt(stddev ** 2 + (acc / accuracy_sigmas) ** 2)
