"""A 2D lidar: beam geometry, ray casting at each beam's time, range noise.

Timing (slam/base.py): scan_t is the time of the first beam of a revolution; beam j is
taken at scan_t + j * time_increment, from the lidar pose at that time (motion
distortion, as a spinning lidar on a moving robot has; `motion_distortion: false` casts
every beam from the pose at scan_t). Angles are counter-clockwise in the lidar frame. No return, a reading outside [range_min, range_max] or a dropped beam is inf.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from sim._raycast import cast_rays_indexed, segment_grid
from sim.noise import LidarNoise
from worlds.paths import names_a_file
from worlds.yamlio import InputError, from_dict, load_yaml

__all__ = ["LidarConfig", "LDS01_NOISE", "lidar_names", "load_lidar", "DEFAULT_LIDAR", "beam_poses", "cast_scans", "apply_range_noise"]


MAX_BEAMS = 10_000      # beams per scan (the catalogue's most: 1081)
MAX_RATE = 200.0        # scans per second (the catalogue's most: 40)
MAX_RANGE = 1000.0      # m
MAX_BEAM_RATE = 100_000.0  # beams per second (the UTM-30LX: 43,240)

# the ROBOTIS LDS-01 datasheet's range noise (sim/lidars/lds-01.yaml gives the sources)
LDS01_NOISE = LidarNoise(drop_prob=0.01, bands=((0.5, 0.015, 0.0), (3.5, 0.0, 0.05)))


@dataclass(frozen=True)
class LidarConfig:
    """A 2D lidar: what its datasheet says (the catalogue, sim/lidars/, has one file per
    model) and how it is mounted (offset). The defaults are the ROBOTIS LDS-01 (HLS-LFCD2)
    and its place on the turtlebot3_burger URDF.

    Beam j points at angle_min_deg + j * increment (counter-clockwise, lidar frame);
    angle_max_deg None means a full revolution, beams 360 / beams degrees apart, else the
    beams span angle_min_deg .. angle_max_deg inclusive, as a ROS LaserScan does. The lidar
    turns at `rate` revolutions per second; beam j is taken j * time_increment after beam 0.
    """

    model: str = "LDS-01"
    beams: int = 360                  # 1 degree apart
    angle_min_deg: float = 0.0        # first beam, degrees counter-clockwise from the lidar's x axis
    angle_max_deg: float | None = None  # last beam; None: a full revolution
    rate: float = 5.0                 # revolutions (scans) per second
    range_min: float = 0.12           # m
    range_max: float = 3.5            # m
    range_resolution: float = 0.001   # m, ranges are quantised to this
    noise: LidarNoise = LDS01_NOISE   # the datasheet's range noise and dropouts
    offset: tuple[float, float, float] = (-0.032, 0.0, 0.0)  # x, y, yaw in the base frame
    motion_distortion: bool = True

    def __post_init__(self):
        # a lidar file from a stranger cannot make a recording of billions of beams
        if not 1 <= self.beams <= MAX_BEAMS:
            raise ValueError(f"beams must be from 1 to {MAX_BEAMS:,}, got {self.beams}")
        if not 0 < self.rate <= MAX_RATE:
            raise ValueError(f"rate must be > 0 and at most {MAX_RATE:g} Hz, got {self.rate}")
        if self.beams * self.rate > MAX_BEAM_RATE:
            raise ValueError(f"beams x rate must be at most {MAX_BEAM_RATE:,.0f} beams per second, "
                             f"got {self.beams * self.rate:,.0f}")
        if self.range_max > MAX_RANGE:
            raise ValueError(f"range_max must be at most {MAX_RANGE:g} m, got {self.range_max}")
        if not 0 <= self.range_min < self.range_max:
            raise ValueError("need 0 <= range_min < range_max")
        if self.range_resolution < 0:
            raise ValueError("range_resolution must be >= 0")
        if not -360.0 <= self.angle_min_deg <= 360.0:
            raise ValueError(f"angle_min_deg must be within +-360, got {self.angle_min_deg}")
        if self.angle_max_deg is not None:
            if self.angle_max_deg < self.angle_min_deg or (self.angle_max_deg == self.angle_min_deg
                                                           and self.beams > 1):
                raise ValueError("angle_max_deg must be above angle_min_deg")
            span = self.angle_max_deg - self.angle_min_deg
            if span + (span / (self.beams - 1) if self.beams > 1 else 0.0) > 360.0 + 1e-9:
                raise ValueError(f"{self.beams} beams over {span} degrees overlap: the field of "
                                 "view is more than a revolution")

    @property
    def full_circle(self) -> bool:
        """True when the beams go all the way round (angle_max_deg None)."""
        return self.angle_max_deg is None

    @property
    def angle_increment(self) -> float:
        """rad between consecutive beams."""
        if self.full_circle:
            return 2.0 * np.pi / self.beams
        if self.beams == 1:
            return 0.0
        return 2.0 * np.pi * ((self.angle_max_deg - self.angle_min_deg) / (self.beams - 1)) / 360.0

    @property
    def field_of_view(self) -> float:
        """rad the beams cover (a full circle: 2 pi)."""
        return 2.0 * np.pi if self.full_circle else self.angle_increment * (self.beams - 1)

    @property
    def scan_time(self) -> float:
        """s per revolution."""
        return 1.0 / self.rate

    @property
    def time_increment(self) -> float:
        """s between consecutive beams: the revolution's time over 360 degrees of beams."""
        if self.full_circle:
            return self.scan_time / self.beams
        return self.scan_time * self.angle_increment / (2.0 * np.pi)

    @property
    def angles(self) -> np.ndarray:
        """(beams,) rad, lidar frame, counter-clockwise."""
        a = np.arange(self.beams) * self.angle_increment
        return a + np.radians(self.angle_min_deg) if self.angle_min_deg else a

    def meta(self) -> dict:
        """What a log's meta.lidar records of this lidar (angles in rad, as a LaserScan)."""
        angles = self.angles
        return {"model": self.model, "beams": self.beams, "rate": self.rate,
                "angle_min": float(angles[0]), "angle_max": float(angles[-1]),
                "angle_increment": self.angle_increment,
                "range_min": self.range_min, "range_max": self.range_max,
                "range_resolution": self.range_resolution,
                "offset": list(self.offset), "scan_time": self.scan_time,
                "time_increment": self.time_increment, "motion_distortion": self.motion_distortion}


DEFAULT_LIDAR = "lds-01"
# the catalogue describes sensors; where a lidar sits on the robot is the recording's choice
_MOUNTING = ("offset", "motion_distortion")


def _catalogue() -> Path:
    return Path(str(resources.files("sim") / "lidars"))


def lidar_names() -> list[str]:
    """Names of the lidars in the catalogue (sim/lidars/<name>.yaml)."""
    return sorted(p.stem for p in _catalogue().glob("*.yaml"))


def load_lidar(lidar: "str | Path | LidarConfig", mounted_as: LidarConfig | None = None) -> LidarConfig:
    """A LidarConfig from a catalogue name ('utm-30lx'), a YAML file of LidarConfig fields or
    a LidarConfig. The file's fields are read over the defaults (the LDS-01); the offset and
    motion distortion of `mounted_as` (the recording's lidar) are kept unless the file sets
    them. InputError for an unknown name or a bad field."""
    if isinstance(lidar, LidarConfig):
        return lidar
    text = str(lidar)
    if names_a_file(text):
        path = Path(text)
    else:
        names = lidar_names()
        if text.lower() not in names:
            raise InputError(f"unknown lidar {text!r} (catalogue: {', '.join(names)}; "
                             "or give a YAML file path)")
        path = _catalogue() / f"{text.lower()}.yaml"
    data = load_yaml(path)
    if data is None or not isinstance(data, dict):
        raise InputError(f"{path}: top level: expected a mapping of lidar fields")
    cfg = from_dict(LidarConfig, data, where=str(path))
    if mounted_as is not None:
        cfg = dataclasses.replace(cfg, **{k: getattr(mounted_as, k) for k in _MOUNTING if k not in data})
    return cfg


def beam_poses(scan_t: np.ndarray, gt_t: np.ndarray, gt_pose: np.ndarray,
               cfg: LidarConfig) -> tuple[np.ndarray, np.ndarray]:
    """Lidar origin and world beam angle of every beam.

    scan_t: (N,) s; gt_t: (L,) s increasing; gt_pose: (L, 3) with yaw unwrapped (continuous).
    Returns origins (N, B, 2) m and angles (N, B) rad (world frame).
    """
    inc = cfg.time_increment if cfg.motion_distortion else 0.0
    t = scan_t[:, None] + np.arange(cfg.beams)[None, :] * inc          # (N, B)
    x = np.interp(t, gt_t, gt_pose[:, 0])
    y = np.interp(t, gt_t, gt_pose[:, 1])
    yaw = np.interp(t, gt_t, gt_pose[:, 2])
    ox, oy, oyaw = cfg.offset
    c, s = np.cos(yaw), np.sin(yaw)
    origins = np.stack([x + c * ox - s * oy, y + s * ox + c * oy], axis=-1)
    angles = yaw + oyaw + cfg.angles[None, :]
    return origins, angles


def cast_scans(segments: np.ndarray, origins: np.ndarray, angles: np.ndarray,
               max_range: float, cell: float = 0.5) -> np.ndarray:
    """True ranges (N, B) m (inf = nothing within max_range) for origins (N, B, 2) and
    world angles (N, B); segments (S, 4). Each beam tests only the segments filed in the
    cells (`cell` m) of a uniform grid it crosses (sim._raycast.cast_rays_indexed)."""
    n, b = angles.shape
    seg = np.ascontiguousarray(segments, dtype=np.float64).reshape(-1, 4)
    grid = segment_grid(seg, cell)
    out = cast_rays_indexed(seg, *grid, np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 2),
                            np.ascontiguousarray(angles, dtype=np.float64).reshape(-1), float(max_range))
    return out.reshape(n, b)


def apply_range_noise(ranges: np.ndarray, noise: LidarNoise, cfg: LidarConfig,
                      rng: np.random.Generator) -> np.ndarray:
    """Measured ranges (same shape as `ranges`, m): Gaussian noise per `noise` (LidarNoise),
    quantised to range_resolution; inf for no return, readings outside
    [range_min, range_max] and dropped beams (probability noise.drop_prob)."""
    r = np.asarray(ranges, dtype=np.float64)
    gauss = rng.standard_normal(r.shape)
    drop = rng.random(r.shape) < noise.drop_prob
    finite = np.isfinite(r)
    rf = np.where(finite, r, 0.0)
    meas = rf + noise.sigma(rf) * gauss
    if cfg.range_resolution > 0:
        meas = np.round(meas / cfg.range_resolution) * cfg.range_resolution
    ok = finite & ~drop & (meas >= cfg.range_min) & (meas <= cfg.range_max)
    return np.where(ok, meas, np.inf)
