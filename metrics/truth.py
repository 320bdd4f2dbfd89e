"""PreparedTruth: a true map with the structures every score against it reuses.

The benchmark scores many maps against one truth, so the occupied-cell centres, their k-d
tree and the coarse correlation images of the global search are built once per truth
(`prepare_truth` keeps the last few in an LRU cache keyed by the Grid object).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from worlds.grid import OCCUPIED_THRESH, Grid
from worlds.yamlio import InputError

__all__ = ["PreparedTruth", "prepare_truth"]


@dataclass(eq=False)
class PreparedTruth:
    """A true map, its occupied cell centres (M, 2) world m and their k-d tree."""

    grid: Grid
    occupied_thresh: float
    occupied: np.ndarray          # (rows, cols) bool
    points: np.ndarray            # (M, 2) world x, y of occupied cell centres
    tree: cKDTree
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def resolution(self) -> float:
        return self.grid.resolution

    def coarse_score(self, cell_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Correlation image for the global search, built once per cell size.

        Returns (score (H, W), lower-left corner (2,) world m): cells of `cell_m` covering
        the occupied points with a 3-cell margin, score = exp(-d^2 / (2 cell_m^2)) with d the
        exact distance from the cell centre to the nearest true occupied cell centre.
        """
        key = ("coarse", round(cell_m, 12))
        if key not in self._cache:
            lo = self.points.min(0) - 3 * cell_m
            hi = self.points.max(0) + 3 * cell_m
            w, h = np.ceil((hi - lo) / cell_m).astype(int) + 1
            cx = lo[0] + (np.arange(w) + 0.5) * cell_m
            cy = lo[1] + (np.arange(h) + 0.5) * cell_m
            gx, gy = np.meshgrid(cx, cy)
            d, _ = self.tree.query(np.stack([gx.ravel(), gy.ravel()], axis=1))
            score = np.exp(-0.5 * (d / cell_m) ** 2).reshape(h, w)
            self._cache[key] = (score, lo)
        return self._cache[key]

    def spectrum(self, cell_m: float, shape: tuple[int, int]) -> np.ndarray:
        """rfft2 of the coarse score image zero-padded to `shape`, cached."""
        key = ("fft", round(cell_m, 12), shape)
        if key not in self._cache:
            score, _ = self.coarse_score(cell_m)
            self._cache[key] = np.fft.rfft2(score, s=shape)
        return self._cache[key]


def _build(grid: Grid, occupied_thresh: float) -> PreparedTruth:
    occ = grid.occupied(occupied_thresh)
    if not occ.any():
        raise InputError("true map has no occupied cell (p >= "
                         f"{occupied_thresh}): nothing to score against")
    r, c = np.nonzero(occ)
    pts = grid.cell_to_world(r, c)
    return PreparedTruth(grid, float(occupied_thresh), occ, pts, cKDTree(pts))


@functools.lru_cache(maxsize=8)
def _cached(grid: Grid, occupied_thresh: float) -> PreparedTruth:
    return _build(grid, occupied_thresh)


def prepare_truth(truth: Grid | PreparedTruth, occupied_thresh: float = OCCUPIED_THRESH) -> PreparedTruth:
    """The PreparedTruth of a true map (cached per Grid object and threshold).

    Raises InputError when the true map has no occupied cell.
    """
    if isinstance(truth, PreparedTruth):
        if truth.occupied_thresh == float(occupied_thresh):
            return truth
        truth = truth.grid
    return _cached(truth, float(occupied_thresh))
