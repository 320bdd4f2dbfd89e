"""RangeNoise: the range error model of a lidar, as the output map weighs its hits.

sigma(r) = sqrt(stddev^2 + (accuracy(r) / accuracy_sigmas)^2), accuracy(r) = near_accuracy
below `split` m and far_accuracy_ratio * r from `split` on: the form lidar datasheets state
(a +- accuracy band read as a 2-sigma bound) plus a range-independent part. A simulated log
carries the model it was recorded with (meta noise.lidar); a log without one (CARMEN, ROS
bags) is read with DEFAULT_RANGE_NOISE, the ROBOTIS LDS-01 datasheet of the TurtleBot3.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

__all__ = ["RangeNoise", "DEFAULT_RANGE_NOISE", "range_noise_from_meta"]


@dataclass(frozen=True)
class RangeNoise:
    """A lidar's range error model (metres; see the module docstring)."""

    stddev: float = 0.0              # m at every range
    near_accuracy: float = 0.015     # m, +- below split (LDS-01: +-15 mm, 0.12-0.5 m)
    far_accuracy_ratio: float = 0.05  # fraction of the range, +- from split on (LDS-01: +-5 %)
    split: float = 0.5               # m
    accuracy_sigmas: float = 2.0     # the +- accuracy is this many standard deviations
    floor: float = 0.001             # m; sigma never below this (an ideal sensor's weights stay finite)

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{f.name} must be a finite number >= 0, got {v!r}")
        if self.accuracy_sigmas <= 0 or self.floor <= 0:
            raise ValueError("accuracy_sigmas and floor must be > 0")

    def sigma(self, r) -> np.ndarray:
        """Range sigma (m) at range(s) r (m)."""
        r = np.asarray(r, dtype=np.float64)
        acc = np.where(r < self.split, self.near_accuracy, self.far_accuracy_ratio * r)
        return np.maximum(np.hypot(self.stddev, acc / self.accuracy_sigmas), self.floor)

    def as_array(self) -> np.ndarray:
        """(6,) stddev, near_accuracy, far_accuracy_ratio, split, accuracy_sigmas, floor."""
        return np.array([self.stddev, self.near_accuracy, self.far_accuracy_ratio, self.split,
                         self.accuracy_sigmas, self.floor], dtype=np.float64)


DEFAULT_RANGE_NOISE = RangeNoise()


def range_noise_from_meta(meta: dict) -> RangeNoise:
    """The range error model a log's meta records (noise.lidar of a simulated log), else
    DEFAULT_RANGE_NOISE. Only the model's own keys are read; a value that is not a finite
    number >= 0 leaves the default."""
    lidar = (meta.get("noise") or {}).get("lidar") if isinstance(meta, dict) else None
    if not isinstance(lidar, dict):
        return DEFAULT_RANGE_NOISE
    keys = {"stddev", "near_accuracy", "far_accuracy_ratio", "split", "accuracy_sigmas"}
    values = {k: lidar[k] for k in keys if k in lidar}
    try:
        return RangeNoise(**{k: float(v) for k, v in values.items()})
    except (TypeError, ValueError):
        return DEFAULT_RANGE_NOISE
