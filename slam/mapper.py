"""Mapper: the occupancy map a run outputs, built by inserting every scan at a given pose.

Shared by the oracle (true poses) and the SLAMs' output maps (their estimated poses), so the
oracle is the ceiling of exactly the same map building. Its defaults are chosen for the
realistic lidar noise (range sigma 2.5 % of the range beyond 0.5 m): hits count only up to
2 m (farther beams mark free space up to 2 m), each hit is smoothed over its 9 neighbouring
beams, and single hits are weak evidence (p_occupied 0.6) so that range noise does not thicken
walls; see the slam README section for the measurements behind these values.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from worlds.grid import Grid
from slam.base import Scan
from slam.occupancy import GridConfig, LogOddsGrid, ReflectanceGrid
from slam.pose import transform_points
from slam.preprocess import PreprocessConfig, ScanPoints, preprocess

__all__ = ["MapperConfig", "MapGridConfig", "MapPreprocessConfig", "Mapper", "insert_scan_points"]


@dataclass(frozen=True)
class MapGridConfig(GridConfig):
    """GridConfig with the output map's defaults (a YAML block keeps those it does not name)."""

    p_free: float = 0.45       # occupancy probability a ray's free cells are updated with
    p_occupied: float = 0.6    # weak single hits: range noise must not make walls thick


@dataclass(frozen=True)
class MapPreprocessConfig(PreprocessConfig):
    """PreprocessConfig with the output map's defaults."""

    range_max: float = 2.0     # m; hits only below 2 m, where the range noise is below 5 cm
    free_range: float = 2.0    # m; farther beams still mark free space up to 2 m
    smooth_beams: int = 4      # mean over 9 neighbouring beams: range noise / 3 on flat walls


@dataclass(frozen=True)
class MapperConfig:
    """How the output map is built: grid update values and the scan preprocessing for it."""

    grid: MapGridConfig = field(default_factory=MapGridConfig)
    preprocess: MapPreprocessConfig = field(default_factory=MapPreprocessConfig)


class Mapper:
    """Inserts scans at given poses into a growing LogOddsGrid."""

    def __init__(self, cfg: MapperConfig, center=(0.0, 0.0)):
        self.cfg = cfg
        self.grid = LogOddsGrid.from_config(cfg.grid, center=tuple(center[:2]))
        self.scans = 0

    def insert(self, scan: Scan, pose: np.ndarray, twist: np.ndarray | None = None) -> None:
        """Insert `scan` taken at robot pose (3,) with the robot moving at twist (3,) (or None)."""
        self.insert_points(preprocess(scan, self.cfg.preprocess, twist), pose)

    def insert_points(self, pts: ScanPoints, pose: np.ndarray) -> None:
        """Insert an already preprocessed scan at robot pose (3,)."""
        insert_scan_points(self.grid, pts, pose)
        self.scans += 1

    def to_grid(self) -> Grid:
        return self.grid.to_grid()


def insert_scan_points(grid: LogOddsGrid | ReflectanceGrid, pts: ScanPoints, pose: np.ndarray) -> None:
    """Rays from the lidar to every hit (occupied end) and miss (free end) of `pts` at robot `pose`."""
    sensor = transform_points(pose, pts.origin[None, :])[0]
    ends = transform_points(pose, np.vstack([pts.points, pts.misses]))
    hits = np.r_[np.ones(len(pts.points), bool), np.zeros(len(pts.misses), bool)]
    grid.insert_scan(sensor, ends, hits)
