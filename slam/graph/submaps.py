"""Submaps of the local SLAM: grids of a fixed number of scans, two active.

As Cartographer's ActiveSubmaps2D: every scan kept by the motion filter goes into both active
submaps; when the newer one has num_range_data scans a new submap starts at the current
pose and the older one, then holding 2 * num_range_data scans, is finished (no more
insertions; the global SLAM searches it for loop closures). A submap's frame has the
translation of its first scan and no rotation. Submap is the probability grid; TSDF submaps
(SubmapsConfig.grid_type "tsdf") are slam.graph.tsdf.TsdfSubmap, with the same interface.
"""
from __future__ import annotations

import numpy as np

from slam.occupancy import LogOddsGrid, logodds
from slam.graph.config import SubmapsConfig
from slam.graph.tsdf import TsdfSubmap

__all__ = ["Submap", "ActiveSubmaps", "TsdfSubmap"]


class Submap:
    """One probability-grid submap in the local frame.

    local_pose: (3,) x, y, 0 of the submap frame in the local SLAM frame; grid: a LogOddsGrid
    in local-frame coordinates (hit/miss odds of Cartographer's probability grid inserter).
    """

    def __init__(self, index: int, origin_xy: np.ndarray, cfg: SubmapsConfig):
        self.index = index
        self.local_pose = np.array([origin_xy[0], origin_xy[1], 0.0])
        self.cfg = cfg
        self.grid = LogOddsGrid(cfg.resolution, center=tuple(origin_xy[:2]),
                                l_free=logodds(cfg.miss_probability), l_occ=logodds(cfg.hit_probability),
                                l_min=logodds(cfg.min_probability), l_max=logodds(cfg.max_probability),
                                block=32, size=8.0, margin=0.3)
        self.num_range_data = 0
        self.finished = False
        self._cache = (-1, None)

    def prepare(self, origin_xy: np.ndarray, hits_xy: np.ndarray, misses_xy: np.ndarray) -> tuple:
        """The scan in the form insert_prepared takes (as given: nothing to share)."""
        return origin_xy, hits_xy, misses_xy

    def insert_prepared(self, scan: tuple) -> None:
        """Insert a scan from prepare()."""
        self.insert(*scan)

    def insert(self, origin_xy: np.ndarray, hits_xy: np.ndarray, misses_xy: np.ndarray) -> None:
        """Insert one scan: origin (2,), hits (N, 2), misses (M, 2), all local frame m."""
        if self.finished:
            raise RuntimeError(f"submap {self.index} is finished")
        pts = np.vstack([hits_xy, misses_xy])
        mask = np.zeros(len(pts), bool)
        mask[:len(hits_xy)] = True
        self.grid.insert_scan(origin_xy, pts, mask, free_margin=self._free_margin(origin_xy, pts, mask))
        self.num_range_data += 1

    def _free_margin(self, origin_xy: np.ndarray, pts: np.ndarray, hit_mask: np.ndarray) -> np.ndarray | None:
        """(N,) m each ray stops freeing short of its end: free_space_margin_sigmas range sigmas
        for hits, 0 for no-return rays; None when the margin is off."""
        k = self.cfg.free_space_margin_sigmas
        if k <= 0:
            return None
        rng = np.hypot(pts[:, 0] - origin_xy[0], pts[:, 1] - origin_xy[1])
        sigma = np.maximum(self.cfg.range_sigma_min, self.cfg.range_sigma_ratio * rng)
        return np.where(hit_mask, k * sigma, 0.0)

    def _logodds_at(self, xy: np.ndarray) -> np.ndarray:
        """(N,) log-odds of the cell under each point (N, 2) local frame m; NaN where never
        observed or outside the grid."""
        r, c, inside = self.grid.cells(xy)
        return np.where(inside, self.grid.logodds[r, c], np.nan)

    def known_at(self, xy: np.ndarray) -> np.ndarray:
        """(N,) bool: the cell under each point (N, 2) local frame m has been observed."""
        return ~np.isnan(self._logodds_at(xy))

    def probability_at(self, xy: np.ndarray) -> np.ndarray:
        """(N,) probability of the cell under each point (N, 2) local frame m; NaN where the
        cell has never been observed or lies outside the grid."""
        return 1.0 / (1.0 + np.exp(-self._logodds_at(xy)))

    def probabilities(self) -> tuple[np.ndarray, np.ndarray]:
        """((rows, cols) probabilities with unknown = min_probability, (5,) grid meta)."""
        version, prob = self._cache
        if version != self.grid.version:
            prob = np.ascontiguousarray(self.grid.prob(unknown=self.cfg.min_probability))
            self._cache = (self.grid.version, prob)
        return prob, self.grid.meta

    def directional(self) -> None:
        """No directional layers (those are TSDF submaps')."""
        return None

    def search_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """The grid the correlative searches score: the probabilities."""
        return self.probabilities()


class ActiveSubmaps:
    """The two submaps scans are inserted into (Cartographer's ActiveSubmaps2D)."""

    def __init__(self, cfg: SubmapsConfig):
        self.cfg = cfg
        self.all: list[Submap] = []
        self.active: list[Submap] = []

    def matching_submap(self) -> Submap | None:
        """The submap scans are matched against: the older active one (the fuller)."""
        return self.active[0] if self.active else None

    def insert(self, origin_xy, hits_xy, misses_xy) -> tuple[list[int], list[int], list[int]]:
        """Insert one scan (local frame). Returns (indices inserted into, new submap indices,
        submaps finished by this insertion)."""
        created, finished = [], []
        if not self.active:
            created.append(self._add(origin_xy))
        inserted = [s.index for s in self.active]
        scan = self.active[0].prepare(origin_xy, hits_xy, misses_xy)    # once for both submaps
        for s in self.active:
            s.insert_prepared(scan)
        if self.active[0].num_range_data >= 2 * self.cfg.num_range_data:
            self.active[0].finished = True
            finished.append(self.active.pop(0).index)
        if self.active[-1].num_range_data >= self.cfg.num_range_data:
            created.append(self._add(origin_xy))
        return inserted, created, finished

    def _add(self, origin_xy) -> int:
        kind = TsdfSubmap if self.cfg.grid_type == "tsdf" else Submap
        s = kind(len(self.all), np.asarray(origin_xy, float), self.cfg)
        self.all.append(s)
        self.active.append(s)
        return s.index
