"""Rendering the output map of `pf` from its count map (hits and visits per cell).

`gmapping` rendering: occupied where hits / visits > occ_thresh, free where visited and not,
unknown elsewhere (what slam_gmapping publishes).

`surface` rendering (default): range noise of a few centimetres spreads a wall's returns
over several cells along the beams, and n / visits marks all of them (the cells behind the
face see only returns). The face is where the returns are densest across the wall, so:
  1. occupied candidates as above, with at least `min_hits` returns;
  2. the candidates' returns are moved by mean shift (two steps, 3 x 3 cells) to the
     densest line of their band, then `into` cells (default 0.2) further into the wall (away
     from the free space: a face on a cell boundary belongs to the wall's cell); the cells
     they end in are the faces;
  3. only cells within reach_cells of free space connected to the robot's path survive
     (the walls' faces; returns overshooting a wall land in pockets the robot never reaches).
Suppressed cells become unknown. Everything is computed from the filter's own map and path.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

__all__ = ["render_gmapping", "render_surface", "reachable_free"]


def render_gmapping(hits: np.ndarray, visits: np.ndarray, occ_thresh: float) -> np.ndarray:
    """(R, C) 1.0 occupied (hits / visits > occ_thresh), 0.0 free, NaN never visited."""
    prob = np.full(visits.shape, np.nan)
    seen = visits > 0
    prob[seen] = (hits[seen] / visits[seen] > occ_thresh).astype(np.float64)
    return prob


def _snap_to_modes(hits, sum_x, sum_y, cand, inward=None, into=0.0, iterations=2):
    """(R, C) votes: the returns of the candidates, counted in the cells they converge to
    by mean shift.

    hits: (R, C) counts; sum_x, sum_y: (R, C) sums of the returns' positions in cell units
    (column, row coordinates); cand: (R, C) bool. Each candidate starts at its cell centre
    and moves `iterations` times to the mean of the returns in the 3 x 3 cells around it;
    the cell it ends in gets the candidate's returns as votes. A wall's returns, spread across a band of cells by range
    noise, all converge onto the band's densest line, one cell thick.
    """
    box = np.ones((3, 3))
    n = ndimage.correlate(hits, box, mode="constant")
    sx = ndimage.correlate(sum_x, box, mode="constant")
    sy = ndimage.correlate(sum_y, box, mode="constant")
    r, c = np.nonzero(cand)
    px, py = c + 0.5, r + 0.5
    rows, cols = hits.shape
    for _ in range(iterations):
        cc = np.clip(np.floor(px).astype(int), 0, cols - 1)
        rr = np.clip(np.floor(py).astype(int), 0, rows - 1)
        w = n[rr, cc]
        ok = w > 0
        px = np.where(ok, sx[rr, cc] / np.where(ok, w, 1), px)
        py = np.where(ok, sy[rr, cc] / np.where(ok, w, 1), py)
    if inward is not None and into > 0:
        # the face cell holds the wall's material: step off the surface into the wall, so a
        # face on a cell boundary lands in the wall's cell, not the free one before it
        cc = np.clip(np.floor(px).astype(int), 0, cols - 1)
        rr = np.clip(np.floor(py).astype(int), 0, rows - 1)
        gx, gy = inward[1][rr, cc], inward[0][rr, cc]
        norm = np.hypot(gx, gy)
        ok = norm > 0
        px = px + np.where(ok, into * gx / np.where(ok, norm, 1), 0.0)
        py = py + np.where(ok, into * gy / np.where(ok, norm, 1), 0.0)
    votes = np.zeros(hits.shape)
    np.add.at(votes, (np.clip(np.floor(py).astype(int), 0, rows - 1),
                      np.clip(np.floor(px).astype(int), 0, cols - 1)), hits[r, c])
    return votes


def reachable_free(prob: np.ndarray, seeds_rc: np.ndarray) -> np.ndarray:
    """(R, C) bool: free cells (prob == 0) 4-connected through free cells to a seed cell.

    seeds_rc: (K, 2) int rows, cols of cells on the robot's path.
    """
    labels, _ = ndimage.label(prob == 0.0)
    r, c = seeds_rc[:, 0], seeds_rc[:, 1]
    inside = (r >= 0) & (r < prob.shape[0]) & (c >= 0) & (c < prob.shape[1])
    keep = np.unique(labels[r[inside], c[inside]])
    return np.isin(labels, keep[keep > 0])


def render_surface(hits: np.ndarray, visits: np.ndarray, sum_x: np.ndarray, sum_y: np.ndarray,
                   occ_thresh: float, min_hits: float, seeds_rc: np.ndarray,
                   reach_cells: int = 2, into: float = 0.2) -> np.ndarray:
    """The `surface` rendering (module docstring). hits, visits: (R, C) counts; sum_x, sum_y:
    (R, C) sums of the returns' positions in cell units (column, row); seeds_rc: (K, 2) rows,
    cols of the robot's path; reach_cells: how far (cells) behind reachable free space a
    face may lie; into: cells the converged returns step into the wall (away from the
    reachable free space) before the cell is marked. Returns (R, C) 1.0 / 0.0 / NaN."""
    prob = render_gmapping(hits, visits, occ_thresh)
    reach = reachable_free(prob, seeds_rc)
    near = ndimage.binary_dilation(reach, iterations=reach_cells)
    occ = prob == 1.0
    cand = occ & (hits >= min_hits) & near
    inward = np.gradient(ndimage.distance_transform_edt(~reach)) if reach.any() else None
    votes = _snap_to_modes(hits, sum_x, sum_y, cand, inward, into)
    keep = (votes > 0) & near & (visits > 0)
    out = prob.copy()
    out[occ & ~keep] = np.nan
    out[keep] = 1.0
    out[(prob == 0.0) & ~reach] = np.nan
    return out
