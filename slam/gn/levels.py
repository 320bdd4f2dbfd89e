"""The matching maps of gn: one occupancy grid per resolution level, updated together."""
from __future__ import annotations

import numpy as np

from slam.gn.config import GnConfig
from slam.occupancy import LogOddsGrid, ReflectanceGrid, insert_scan_points, logodds

__all__ = ["MapLevels"]


class _Level:
    """One map level: its grid and the probability image the matcher reads (cached)."""

    def __init__(self, grid: LogOddsGrid | ReflectanceGrid, unknown: float):
        self.grid = grid
        self.unknown = float(unknown)
        self._prob = None
        self._meta = None
        self._version = -1

    def prob_meta(self) -> tuple[np.ndarray, np.ndarray]:
        if self._version != self.grid.version:
            # never-touched cells read as match_unknown (hector: log-odds 0, p = 0.5)
            self._prob = np.ascontiguousarray(self.grid.prob(unknown=self.unknown))
            self._meta = self.grid.meta
            self._version = self.grid.version
        return self._prob, self._meta


class MapLevels:
    """The multi-resolution map, finest level first (level k has 2^k x the finest cell size)."""

    def __init__(self, cfg: GnConfig, center):
        self.levels = [_Level(self._grid(cfg, res, center), cfg.match_unknown) for res in cfg.resolutions]
        self.iterations = [cfg.iterations_finest] + [cfg.iterations_coarse] * (cfg.map_multi_res_levels - 1)

    @staticmethod
    def _grid(cfg: GnConfig, resolution: float, center) -> LogOddsGrid | ReflectanceGrid:
        if cfg.map_type == "reflectance_count":
            return ReflectanceGrid(resolution, center)
        return LogOddsGrid(resolution, center, logodds(cfg.update_factor_free),
                           logodds(cfg.update_factor_occupied), cfg.logodds_min, cfg.logodds_max)

    def images(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """[(prob (rows, cols), grid_meta (5,))] of every level, finest first."""
        return [lv.prob_meta() for lv in self.levels]

    def observed(self, xy: np.ndarray) -> np.ndarray:
        """(N,) bool: the points (N, 2) world m lie in cells the coarsest level has observed."""
        return self.levels[-1].grid.observed(xy)

    def insert(self, pts, pose: np.ndarray) -> None:
        """Insert a preprocessed scan at pose (3,) into every level."""
        for lv in self.levels:
            insert_scan_points(lv.grid, pts, pose)
