"""Noise profiles: documented sets of sensor and wheel-slip noise numbers.

A profile is loaded by name from sim/profiles/<name>.yaml (shipped with the package:
`ideal`, `gazebo`, `realistic`) or from a user's YAML path; unknown keys are rejected.
Every number's source is given in the profile YAML files and in the field comments here.

Conventions:
- White noise is Gaussian. A sensor's per-sample standard deviation is
  sqrt(stddev**2 + density**2 * rate): `stddev` for models given per sample (Gazebo),
  `density` for datasheet noise densities (per sqrt(Hz)), `rate` the sample rate.
- A datasheet "accuracy +-X" is read as a 2-sigma bound of zero-mean Gaussian noise
  (about 95% of readings within +-X), i.e. sigma = X / 2 (`accuracy_sigmas`).
- Biases follow Gazebo's GaussianNoiseModel: a constant bias drawn once per run as
  N(bias_mean, bias_stddev) with a random sign, plus (ours) a random walk of
  `bias_walk` (unit/s per sqrt(s)) for the slow in-run drift of a MEMS gyro.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from sim.logs.range_model import accuracy_bands, check_bands, range_sigma
from worlds.paths import names_a_file
from worlds.yamlio import InputError, from_dict, load_yaml, to_dict

__all__ = ["LidarNoise", "WheelNoise", "ImuAxisNoise", "ImuNoise", "NoiseProfile",
           "load_profile", "profile_names"]


@dataclass(frozen=True)
class LidarNoise:
    """Range noise of a lidar: Gaussian with sigma = sqrt(stddev^2 + (accuracy(r) /
    accuracy_sigmas)^2), and `drop_prob` of the beams return nothing (inf).

    accuracy(r), the datasheet's +- accuracy at range r (m), is given by range band:
    `bands` [[up_to, accuracy, ratio], ...] in increasing up_to, accuracy(r) = accuracy +
    ratio * r in the first band with r < up_to (the last band also covers every range past
    it). Without bands: near_accuracy below `split` m and far_accuracy_ratio * r from `split`
    on (the LDS-01's two bands, the form the shipped profiles were first written in)."""

    stddev: float = 0.0              # m, range-independent (Gazebo's ray sensor noise)
    near_accuracy: float = 0.0       # m, +- accuracy below split
    far_accuracy_ratio: float = 0.0  # fraction of the range, +- accuracy from split on
    split: float = 0.5               # m
    accuracy_sigmas: float = 2.0     # the +- accuracy is this many standard deviations
    drop_prob: float = 0.0           # probability a beam returns nothing
    bands: tuple[tuple[float, float, float], ...] = ()  # [up_to m, accuracy m, ratio] by range

    def __post_init__(self):
        _check_nonneg(self, ("stddev", "near_accuracy", "far_accuracy_ratio", "split"))
        if self.accuracy_sigmas <= 0:
            raise ValueError("accuracy_sigmas must be > 0")
        if not 0.0 <= self.drop_prob < 1.0:
            raise ValueError(f"drop_prob must be in [0, 1), got {self.drop_prob}")
        object.__setattr__(self, "bands", check_bands(self.bands))

    def accuracy_bands(self) -> tuple[tuple[float, float, float], ...]:
        """The bands (up_to, accuracy, ratio) this model reads accuracy(r) from."""
        return accuracy_bands(self.bands, self.near_accuracy, self.far_accuracy_ratio, self.split)

    def sigma(self, r) -> np.ndarray:
        """Range sigma (m) at range(s) r (m)."""
        return range_sigma(r, self.stddev, self.accuracy_bands(), self.accuracy_sigmas)


@dataclass(frozen=True)
class WheelNoise:
    """Difference between what the wheels turn (encoders) and how the robot moves.

    Systematic, drawn once per run (Borenstein & Feng 1996, UMBmark): each wheel's
    effective radius is off by N(0, radius_error) (fraction), the effective wheel
    separation by N(0, separation_error) (fraction). Random slip: each wheel's ground
    travel over a step of wheel travel d differs by N(0, slip_density**2 * |d|) (m), the
    variance growing with distance as in Chong & Kleeman 1997.
    """

    radius_error: float = 0.0        # fraction, 1 sigma
    separation_error: float = 0.0    # fraction, 1 sigma
    slip_density: float = 0.0        # m per sqrt(m) of wheel travel, 1 sigma

    def __post_init__(self):
        _check_nonneg(self, ("radius_error", "separation_error", "slip_density"))


@dataclass(frozen=True)
class ImuAxisNoise:
    """Noise of one IMU channel (gyro z in rad/s, or an accelerometer axis in m/s^2)."""

    stddev: float = 0.0        # per sample
    density: float = 0.0       # per sqrt(Hz)
    bias_mean: float = 0.0     # magnitude of the constant bias (random sign)
    bias_stddev: float = 0.0   # spread of the constant bias
    bias_walk: float = 0.0     # bias random walk, unit per sqrt(s)

    def __post_init__(self):
        _check_nonneg(self, ("stddev", "density", "bias_mean", "bias_stddev", "bias_walk"))

    def sigma(self, rate: float) -> float:
        """Per-sample white-noise standard deviation at `rate` Hz."""
        return float((self.stddev ** 2 + self.density ** 2 * rate) ** 0.5)


@dataclass(frozen=True)
class ImuNoise:
    gyro: ImuAxisNoise = field(default_factory=ImuAxisNoise)
    accel: ImuAxisNoise = field(default_factory=ImuAxisNoise)


@dataclass(frozen=True)
class NoiseProfile:
    """All noise of one recording. `name` identifies the profile in logs. `lidar` None (the
    realistic profile) takes the range noise from the lidar's datasheet (LidarConfig.noise,
    sim/lidars/); a profile that sets it applies it to any lidar."""

    name: str = "custom"
    description: str = ""
    lidar: LidarNoise | None = None   # None: the recording lidar's own datasheet noise
    wheels: WheelNoise = field(default_factory=WheelNoise)
    imu: ImuNoise = field(default_factory=ImuNoise)

    def to_dict(self) -> dict:
        return to_dict(self)


def _check_nonneg(obj, names):
    for n in names:
        v = getattr(obj, n)
        if v < 0:
            raise ValueError(f"{n} must be >= 0, got {v}")


def profile_names() -> list[str]:
    """Names of the profiles shipped in sim/profiles/."""
    root = resources.files("sim") / "profiles"
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".yaml"))


def load_profile(noise: "str | Path | NoiseProfile") -> NoiseProfile:
    """A NoiseProfile from a shipped profile name, a YAML path or a NoiseProfile.

    Raises InputError for an unknown name, an unreadable file or a bad field.
    """
    if isinstance(noise, NoiseProfile):
        return noise
    text = str(noise)
    if not names_a_file(text):
        names = profile_names()
        if text not in names:
            raise InputError(f"unknown noise profile {text!r} (known: {', '.join(names)}; "
                             f"or give a YAML file path)")
        path = Path(str(resources.files("sim") / "profiles" / f"{text}.yaml"))
        data = load_yaml(path)
        data = {"name": text, **(data or {})}
    else:
        path = Path(text)
        data = load_yaml(path)
        if isinstance(data, dict) and "name" not in data:
            data = {"name": path.stem, **data}
    return from_dict(NoiseProfile, data, where=str(path))
