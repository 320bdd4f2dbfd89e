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

    def normals(self) -> tuple[np.ndarray, np.ndarray]:
        """Per true cell: unit normal (M, 2) of the wall through it and a weight (M,) in [0, 1].

        Principal axes of the true cells within 2.5 cells: the normal is the minor axis, the
        weight 1 - minor/major eigenvalue (1 on a straight wall, ~0 at a corner or an isolated
        cell, where no line is defined). Built once per truth.
        """
        if "normals" not in self._cache:
            self._cache["normals"] = _cell_normals(self.points, self.tree, 2.5 * self.resolution)
        return self._cache["normals"]

    def spectrum(self, cell_m: float, shape: tuple[int, int]) -> np.ndarray:
        """rfft2 of the coarse score image zero-padded to `shape`, cached."""
        key = ("fft", round(cell_m, 12), shape)
        if key not in self._cache:
            score, _ = self.coarse_score(cell_m)
            self._cache[key] = np.fft.rfft2(score, s=shape)
        return self._cache[key]


def _cell_normals(points: np.ndarray, tree: cKDTree, radius: float) -> tuple[np.ndarray, np.ndarray]:
    m = len(points)
    pairs = tree.query_pairs(radius, output_type="ndarray")
    # neighbourhood sums over both directions of each pair plus the point itself
    i = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(m)])
    j = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(m)])
    cnt = np.bincount(i, minlength=m).astype(np.float64)
    q = points[j]
    mean = np.stack([np.bincount(i, q[:, 0], m), np.bincount(i, q[:, 1], m)], axis=1) / cnt[:, None]
    d = q - mean[i]
    sxx = np.bincount(i, d[:, 0] * d[:, 0], m) / cnt
    syy = np.bincount(i, d[:, 1] * d[:, 1], m) / cnt
    sxy = np.bincount(i, d[:, 0] * d[:, 1], m) / cnt
    # closed-form eigen decomposition of the 2x2 covariance [[sxx, sxy], [sxy, syy]]
    half_tr = 0.5 * (sxx + syy)
    disc = np.sqrt(np.maximum(0.25 * (sxx - syy) ** 2 + sxy ** 2, 0.0))
    lam_max, lam_min = half_tr + disc, half_tr - disc
    # major axis angle; the normal is perpendicular to it
    ang = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    normals = np.stack([-np.sin(ang), np.cos(ang)], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        weight = np.where(lam_max > 0, 1.0 - lam_min / lam_max, 0.0)
    weight[cnt < 3] = 0.0
    return normals, np.clip(weight, 0.0, 1.0)


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
