"""The output map: the map every algorithm writes, built the same way by all of them.

Each scan is inserted at the pose the algorithm estimated for it (the oracle: the true pose),
de-skewed with the motion during its revolution, into one log-odds grid. So the maps of two
algorithms differ only where their poses differ, and the oracle's map is the ceiling of
exactly this map building. The defaults suit a lidar whose range error grows with range (the
LDS-01: 2.5 % of the range, 1 sigma, beyond 0.5 m): hits count only up to 2 m (farther beams
mark free space up to 2 m), each hit is the mean of its 9 neighbouring beams, and one hit is
weak evidence (p_occupied 0.6), so that range noise does not thicken the walls.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from worlds.grid import Grid
from slam.base import Scan
from slam.occupancy import GridConfig, LogOddsGrid, insert_scan_points
from slam.preprocess import PreprocessConfig, ScanPoints, preprocess, twist_from_poses

__all__ = ["OutputMapConfig", "OutputGridConfig", "OutputPreprocessConfig", "OutputMap",
           "output_map_from_trajectory"]


@dataclass(frozen=True)
class OutputGridConfig(GridConfig):
    """GridConfig with the output map's defaults (a YAML block keeps those it does not name)."""

    p_free: float = 0.45       # occupancy probability a ray's free cells are updated with
    p_occupied: float = 0.6    # weak single hits: range noise must not make walls thick


@dataclass(frozen=True)
class OutputPreprocessConfig(PreprocessConfig):
    """PreprocessConfig with the output map's defaults."""

    range_max: float = 2.0     # m; hits only below 2 m, where the range noise is below 5 cm
    free_range: float = 2.0    # m; farther beams still mark free space up to 2 m
    smooth_beams: int = 4      # mean over 9 neighbouring beams: range noise / 3 on flat walls


@dataclass(frozen=True)
class OutputMapConfig:
    """How the output map is built: grid update values and the scan preprocessing for it."""

    grid: OutputGridConfig = field(default_factory=OutputGridConfig)
    preprocess: OutputPreprocessConfig = field(default_factory=OutputPreprocessConfig)


class OutputMap:
    """Inserts scans at given poses into a growing LogOddsGrid."""

    def __init__(self, cfg: OutputMapConfig, center=(0.0, 0.0)):
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
        """The map as a Grid (probabilities, NaN unknown), cropped to the observed cells."""
        return self.grid.to_grid()


def output_map_from_trajectory(cfg: OutputMapConfig, scans: list[Scan], times: np.ndarray,
                               poses: np.ndarray) -> Grid:
    """The output map of scans (N) at poses (N, 3) taken at times (N,): each scan de-skewed with
    the motion from its pose to the next (the last one: from the previous to it)."""
    out = OutputMap(cfg, center=tuple(poses[0][:2]))
    for i, scan in enumerate(scans):
        j, k = (i, i + 1) if i + 1 < len(poses) else (i - 1, i)
        twist = twist_from_poses(poses[j], poses[k], times[k] - times[j]) if j >= 0 else np.zeros(3)
        out.insert(scan, poses[i], twist)
    return out.to_grid()
