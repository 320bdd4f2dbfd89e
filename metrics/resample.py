"""Resampling an aligned estimate onto the true map's grid (extended to hold all of it).

The estimate's probabilities on the target grid are the union of two samplings:
- pull (nearest): each target cell takes the estimate cell under its centre, mapped back
  through the inverse transform; this keeps free space and coarse estimates (one coarse
  occupied cell covers every fine target cell whose centre falls in it);
- push (max-pool): each estimated occupied cell centre, mapped forward, marks the target cell
  it falls in with its probability when that is higher; this keeps every occupied cell of a
  finer estimate (max-pooling) and of a rotated thin wall that the pull sampling could skip.
With the same resolution and an aligned grid both samplings are the identity, so identical
maps resample exactly onto each other.
"""
from __future__ import annotations

import numpy as np

from slam.pose import compose, inverse, transform_points
from worlds.grid import Grid

__all__ = ["extended_grid", "resample_onto"]


def extended_grid(truth: Grid, points: np.ndarray, margin_cells: int = 2) -> tuple[Grid, tuple[int, int]]:
    """The truth's grid padded (with unknown cells) to contain `points` (N, 2) world m.

    Returns (padded grid, (rows_below, cols_left)): the truth sits at
    padded.prob[rows_below:rows_below + truth.rows, cols_left:cols_left + truth.cols].
    """
    r0 = c0 = r1 = c1 = 0
    if len(points):
        m = truth.world_to_map(points)
        c0 = max(0, int(np.ceil(-m[:, 0].min())) + margin_cells)
        r0 = max(0, int(np.ceil(-m[:, 1].min())) + margin_cells)
        c1 = max(0, int(np.ceil(m[:, 0].max() - truth.cols)) + margin_cells)
        r1 = max(0, int(np.ceil(m[:, 1].max() - truth.rows)) + margin_cells)
    if r0 == c0 == r1 == c1 == 0:
        return truth, (0, 0)
    prob = np.pad(truth.prob, ((r0, r1), (c0, c1)), constant_values=np.nan)
    origin = compose(truth.origin, np.array([-c0 * truth.resolution, -r0 * truth.resolution, 0.0]))
    return Grid(prob, truth.resolution, origin), (r0, c0)


def resample_onto(estimate: Grid, pose: np.ndarray, target: Grid,
                  occupied_thresh: float = 0.65) -> np.ndarray:
    """Estimate probabilities on the target grid after the transform `pose` (estimate -> target world).

    Returns (target.rows, target.cols) float64 probabilities, NaN where unknown or outside
    the estimate. Pull sampling for every cell, then push (max) of occupied cells, see module doc.
    """
    pose = np.asarray(pose, dtype=np.float64)
    rr, cc = np.indices(target.shape)
    centres = target.cell_to_world(rr.ravel(), cc.ravel())
    back = transform_points(inverse(pose), centres)
    er, ec = estimate.world_to_cell(back)
    inside = estimate.in_bounds(er, ec)
    out = np.full(target.rows * target.cols, np.nan)
    out[inside] = estimate.prob[er[inside], ec[inside]]
    out = out.reshape(target.shape)

    occ = estimate.occupied(occupied_thresh)
    orow, ocol = np.nonzero(occ)
    if len(orow):
        fwd = transform_points(pose, estimate.cell_to_world(orow, ocol))
        tr, tc = target.world_to_cell(fwd)
        ok = target.in_bounds(tr, tc)
        vals = estimate.prob[orow[ok], ocol[ok]]
        # fmax: NaN (unknown) loses to any probability
        np.fmax.at(out, (tr[ok], tc[ok]), vals)
    return out
