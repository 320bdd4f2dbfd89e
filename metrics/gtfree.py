"""Map quality without ground truth, after Filatov et al. 2017 ("2D SLAM quality evaluation
methods"): a blurred or doubled map has more occupied cells, more corners and more enclosed
areas than a clean one of the same place.

- occupied_fraction, free_fraction: shares of occupied (p >= 0.65) and free (p <= 0.2) cells
  among known cells.
- corners: Shi-Tomasi corners (Shi & Tomasi 1994) of the occupied-cell image: the smaller
  eigenvalue of the structure tensor (Sobel gradients, Gaussian window sigma = 1 cell), local
  maxima in a 5 x 5 window above 10 % of the response of an ideal right-angle corner (a
  fixed threshold, so counts compare across maps).
- enclosed_areas: 4-connected regions of non-occupied (free or unknown) cells that do not reach
  the map border, i.e. areas fully walled in by occupied cells (8-connected walls).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from metrics.result import Result
from worlds.grid import FREE_THRESH, OCCUPIED_THRESH, Grid

__all__ = ["MapQuality", "map_quality", "gtfree_metrics", "corner_response", "count_corners",
           "count_enclosed_areas"]

_SIGMA = 1.0
_QUALITY = 0.1


def corner_response(img: np.ndarray, sigma: float = _SIGMA) -> np.ndarray:
    """Shi-Tomasi response (rows, cols): smaller eigenvalue of the smoothed structure tensor of img."""
    img = np.asarray(img, dtype=np.float64)
    gx = ndimage.sobel(img, axis=1, mode="constant") / 8.0
    gy = ndimage.sobel(img, axis=0, mode="constant") / 8.0
    sxx = ndimage.gaussian_filter(gx * gx, sigma, mode="constant")
    syy = ndimage.gaussian_filter(gy * gy, sigma, mode="constant")
    sxy = ndimage.gaussian_filter(gx * gy, sigma, mode="constant")
    half_tr = 0.5 * (sxx + syy)
    disc = np.sqrt(np.maximum(0.25 * (sxx - syy) ** 2 + sxy * sxy, 0.0))
    return half_tr - disc


@functools.lru_cache(maxsize=4)
def _ideal_corner(sigma: float) -> float:
    img = np.zeros((21, 21))
    img[10:, 10:] = 1.0
    return float(corner_response(img, sigma).max())


def count_corners(occupied: np.ndarray, sigma: float = _SIGMA, quality: float = _QUALITY) -> int:
    """Number of Shi-Tomasi corners of a (rows, cols) bool occupied mask (see module doc)."""
    img = np.pad(np.asarray(occupied, dtype=np.float64), 3)
    resp = corner_response(img, sigma)
    thresh = quality * _ideal_corner(sigma)
    peaks = (resp >= thresh) & (resp == ndimage.maximum_filter(resp, size=5, mode="constant"))
    # plateaus of equal response count once
    _, n = ndimage.label(peaks, structure=np.ones((3, 3), bool))
    return int(n)


def count_enclosed_areas(occupied: np.ndarray, min_cells: int = 1) -> int:
    """Regions of non-occupied cells (4-connected) cut off from the border by occupied cells."""
    open_ = np.pad(~np.asarray(occupied, dtype=bool), 1, constant_values=True)
    labels, n = ndimage.label(open_)  # default structure: 4-connectivity
    if n == 0:
        return 0
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    outside = labels[0, 0]
    keep = sizes >= min_cells
    keep[0] = False
    keep[outside] = False
    return int(keep.sum())


@dataclass(frozen=True)
class MapQuality(Result):
    """The ground-truth-free metrics of one map (see the module docstring)."""

    occupied_fraction: float
    free_fraction: float
    corners: int
    enclosed_areas: int


def map_quality(grid: Grid, occupied_thresh: float = OCCUPIED_THRESH,
                free_thresh: float = FREE_THRESH) -> MapQuality:
    """occupied_fraction, free_fraction (of known cells; 0 when nothing is known), corners and
    enclosed_areas of one map."""
    occ = grid.occupied(occupied_thresh)
    known = int(grid.known().sum())
    return MapQuality(float(occ.sum() / known) if known else 0.0,
                      float(grid.free(free_thresh).sum() / known) if known else 0.0,
                      count_corners(occ), count_enclosed_areas(occ))


def gtfree_metrics(grid: Grid, occupied_thresh: float = OCCUPIED_THRESH,
                   free_thresh: float = FREE_THRESH) -> dict:
    """map_quality(...).as_dict()."""
    return map_quality(grid, occupied_thresh, free_thresh).as_dict()
