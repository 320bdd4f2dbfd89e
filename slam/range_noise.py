"""RangeNoise: the range error model of a lidar, as the output map weighs its hits.

sigma(r) = sqrt(stddev^2 + (accuracy(r) / accuracy_sigmas)^2), accuracy(r) the datasheet's
+- accuracy at range r by range band (`bands` [[up_to, accuracy, ratio], ...]: accuracy +
ratio * r in the first band with r < up_to, the last band past it; without bands,
near_accuracy below `split` m and far_accuracy_ratio * r from `split` on): the form lidar
datasheets state (a +- accuracy band read as a 2-sigma bound) plus a range-independent part,
as sim.noise.LidarNoise. A simulated log carries the model it was recorded with (meta
noise.lidar); a log without one (CARMEN, ROS bags) is read with DEFAULT_RANGE_NOISE, the
ROBOTIS LDS-01 datasheet of the TurtleBot3.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from sim.logs.range_model import accuracy_bands, check_bands, range_sigma

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
    bands: tuple[tuple[float, float, float], ...] = ()  # [up_to m, accuracy m, ratio] by range

    def __post_init__(self):
        object.__setattr__(self, "bands", check_bands(self.bands))
        for f in fields(self):
            if f.name == "bands":
                continue
            v = getattr(self, f.name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{f.name} must be a finite number >= 0, got {v!r}")
        if self.accuracy_sigmas <= 0 or self.floor <= 0:
            raise ValueError("accuracy_sigmas and floor must be > 0")

    def accuracy_bands(self) -> tuple[tuple[float, float, float], ...]:
        """The bands (up_to, accuracy, ratio) this model reads accuracy(r) from."""
        return accuracy_bands(self.bands, self.near_accuracy, self.far_accuracy_ratio, self.split)

    def sigma(self, r) -> np.ndarray:
        """Range sigma (m) at range(s) r (m)."""
        return np.maximum(range_sigma(r, self.stddev, self.accuracy_bands(), self.accuracy_sigmas),
                          self.floor)

    def as_array(self) -> np.ndarray:
        """(4 + 3 K,) stddev, accuracy_sigmas, floor, K, then up_to, accuracy, ratio of each of
        the K bands: the form the numba kernels read (slam/_kernels/surface_map.py)."""
        bands = self.accuracy_bands()
        return np.array([self.stddev, self.accuracy_sigmas, self.floor, len(bands),
                         *(v for b in bands for v in b)], dtype=np.float64)


DEFAULT_RANGE_NOISE = RangeNoise()


def range_noise_from_meta(meta: dict) -> RangeNoise:
    """The range error model a log's meta records (noise.lidar of a simulated log), else
    DEFAULT_RANGE_NOISE. Only the model's own keys are read; a value that is not a finite
    number >= 0 leaves the default."""
    lidar = (meta.get("noise") or {}).get("lidar") if isinstance(meta, dict) else None
    if not isinstance(lidar, dict):
        return DEFAULT_RANGE_NOISE
    keys = {"stddev", "near_accuracy", "far_accuracy_ratio", "split", "accuracy_sigmas"}
    values = {k: float(lidar[k]) for k in keys if k in lidar}
    try:
        if lidar.get("bands"):
            values["bands"] = tuple(tuple(float(v) for v in b) for b in lidar["bands"])
        return RangeNoise(**values)
    except (TypeError, ValueError):
        return DEFAULT_RANGE_NOISE
