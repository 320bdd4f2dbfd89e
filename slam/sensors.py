"""What a log says about its sensors: the facts every algorithm's defaults derive from, and
the derivation record (`Derived`) that `slam run --explain` prints.

An algorithm's `derive_config(sensors)` (slam.base.Slam) turns a SensorFacts into a list of
Derived values (a dotted config path, the value, the rule that gave it); slam.registry puts
them between the config class's defaults and the user's YAML, so a value set in a config file
still wins. Nothing here reads ground truth: only the scans, the odometry and IMU timing and
the log's meta.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sim.logs import SensorLog
from slam.pose import interpolate_poses
from slam.range_noise import RangeNoise, range_noise_from_meta
from worlds.yamlio import from_dict

__all__ = ["SensorFacts", "Derived", "sensor_facts", "apply_derived", "noise_smoothing_beams", "REFERENCE_RATE"]

# the LDS-01's scan rate, Hz: the rate at which the defaults that count scans (pf's motion noise,
# drawn per scan taken; graph's motion-filter angle) were set
REFERENCE_RATE = 5.0


@dataclass(frozen=True)
class SensorFacts:
    """A log's sensors, as the defaults need them.

    range_min, range_max: m (the lidar's limits); beams; angle_increment: rad between beams;
    field_of_view: rad the beams cover (2 pi for a full revolution); scan_rate: scans per s;
    time_increment: s between beams (0: unknown); range_noise: the range error model
    (noise_known False: the documented default, the log names none); median_range: m, of the
    returns; odometry, imu: present; odom_rate, imu_rate: Hz (0 when absent); scan_step,
    scan_turn: median odometry motion between consecutive scans (m, rad; 0 without odometry).
    """

    range_min: float
    range_max: float
    beams: int
    angle_increment: float
    field_of_view: float
    scan_rate: float
    time_increment: float
    range_noise: RangeNoise
    noise_known: bool
    median_range: float
    odometry: bool
    odom_rate: float
    imu: bool
    imu_rate: float
    scan_step: float
    scan_turn: float

    @property
    def full_circle(self) -> bool:
        """True when the beams go all the way round."""
        return self.field_of_view >= 2.0 * math.pi - 1e-6


@dataclass(frozen=True)
class Derived:
    """One value an algorithm took from the log: `path` (dotted, as in the YAML), `value`, and
    the rule that gave it, in words."""

    path: str
    value: Any
    rule: str


def _rate(t: np.ndarray) -> float:
    d = np.diff(np.asarray(t, dtype=np.float64))
    d = d[d > 0]
    return float(1.0 / np.median(d)) if len(d) else 0.0


def sensor_facts(log: SensorLog, max_scans: int = 500) -> SensorFacts:
    """The SensorFacts of `log` (the median range from at most `max_scans` scans, evenly spread)."""
    angles = np.asarray(log.scan_angles, dtype=np.float64)
    beams = int(angles.size)
    inc = float(np.median(np.abs(np.diff(angles)))) if beams > 1 else 0.0
    span = abs(float(angles[-1] - angles[0])) + inc if beams else 0.0
    fov = min(span, 2.0 * math.pi) if span < 2.0 * math.pi - 0.5 * inc else 2.0 * math.pi
    lidar = log.meta.get("lidar", {}) if isinstance(log.meta.get("lidar"), dict) else {}
    noise_meta = log.meta.get("noise") if isinstance(log.meta.get("noise"), dict) else {}
    pick = np.linspace(0, log.n_scans - 1, min(max_scans, log.n_scans)).astype(int) if log.n_scans else []
    r = log.scan_ranges[pick].reshape(-1) if len(pick) else np.zeros(0)
    r = r[np.isfinite(r) & (r > max(log.range_min, 0.0)) & (r < log.range_max)]
    step = turn = 0.0
    if log.has_odometry and log.n_scans > 1:
        at = interpolate_poses(log.scan_t, log.odom_t, log.odom_pose)
        step = float(np.median(np.hypot(*np.diff(at[:, :2], axis=0).T)))
        turn = float(np.median(np.abs(np.diff(at[:, 2]))))
    return SensorFacts(
        range_min=float(log.range_min), range_max=float(log.range_max), beams=beams,
        angle_increment=inc, field_of_view=fov, scan_rate=_rate(log.scan_t),
        time_increment=float(lidar.get("time_increment", 0.0) or 0.0),
        range_noise=range_noise_from_meta(log.meta),
        noise_known=isinstance(noise_meta.get("lidar"), dict),
        median_range=float(np.median(r)) if len(r) else 0.0,
        odometry=bool(log.has_odometry), odom_rate=_rate(log.odom_t) if log.has_odometry else 0.0,
        imu=bool(log.has_imu), imu_rate=_rate(log.imu_t) if log.has_imu else 0.0,
        scan_step=step, scan_turn=turn)


def noise_smoothing_beams(facts: SensorFacts, cell: float, at_range: float = 2.0,
                          most: int = 4) -> int:
    """Half window k of the beam smoothing (2k + 1 neighbouring beams averaged) that brings the
    range noise at `at_range` m to a quarter of a `cell` m cell on a flat wall:
    (2k + 1) >= (sigma / (cell / 4))^2, at most `most`."""
    sigma = float(facts.range_noise.sigma(min(at_range, facts.range_max)))
    need = (sigma / (cell / 4.0)) ** 2
    return int(min(most, max(0, math.ceil((need - 1.0) / 2.0))))


def apply_derived(config: Any, derived: list[Derived]) -> Any:
    """`config` (a dataclass) with each derived value set at its dotted path, checked as a
    config file's value is (worlds.yamlio.from_dict)."""
    data: dict = {}
    for d in derived:
        *parents, leaf = d.path.split(".")
        level = data
        for part in parents:
            level = level.setdefault(part, {})
        level[leaf] = d.value
    return from_dict(type(config), data, where="<derived from the log>", base=config)
