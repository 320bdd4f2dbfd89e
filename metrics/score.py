"""score_map: every map metric of one estimated map against the true map, in one call.

Steps: occupied cell centres of the estimate -> alignment (align.py) -> the estimate resampled
onto the truth's grid, extended to hold all of it (resample.py) -> TP/FP/FN (grid_portion.py),
ADNN both ways (adnn.py), SSIM (ssim.py) and the ground-truth-free metrics of the estimate
(gtfree.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from metrics.adnn import adnn_metrics
from metrics.align import AlignConfig, align_points
from metrics.grid_portion import Classification, classify_masks
from metrics.gtfree import gtfree_metrics
from metrics.resample import extended_grid, resample_onto
from metrics.ssim import ssim
from metrics.truth import PreparedTruth, prepare_truth
from slam.pose import transform_points
from worlds.grid import OCCUPIED_THRESH, Grid

__all__ = ["score_map", "classify", "Overlay", "save_overlay_png", "pose_of"]


@dataclass(frozen=True)
class Overlay:
    """The estimate on the (extended) truth grid: `grid` geometry, estimate probabilities
    `est_prob` (rows, cols), true probabilities `true_prob` and the TP/FP/FN classification."""

    grid: Grid
    est_prob: np.ndarray
    true_prob: np.ndarray
    classes: Classification


def pose_of(align) -> np.ndarray:
    """(3,) pose from a transform given as (x, y, yaw), a (3,) array or {"x", "y", "yaw"}."""
    if isinstance(align, dict):
        return np.array([align["x"], align["y"], align["yaw"]], dtype=np.float64)
    return np.asarray(align, dtype=np.float64).reshape(3)


def _overlay(estimate: Grid, truth: PreparedTruth, pose: np.ndarray, est_pts: np.ndarray,
             tolerance: int, occupied_thresh: float) -> Overlay:
    aligned = transform_points(pose, est_pts)
    corners = estimate.cell_to_world(np.array([0, 0, estimate.rows - 1, estimate.rows - 1]),
                                     np.array([0, estimate.cols - 1, 0, estimate.cols - 1]))
    # the canvas holds the estimate's occupied cells; its free space may be cropped beyond 2 cells
    extent_pts = aligned if len(aligned) else transform_points(pose, corners)
    canvas, (r0, c0) = extended_grid(truth.grid, extent_pts)
    est_prob = resample_onto(estimate, pose, canvas, occupied_thresh)
    true_occ = np.zeros(canvas.shape, bool)
    true_occ[r0:r0 + truth.grid.rows, c0:c0 + truth.grid.cols] = truth.occupied
    with np.errstate(invalid="ignore"):
        est_occ = est_prob >= occupied_thresh
    return Overlay(canvas, est_prob, canvas.prob, classify_masks(est_occ, true_occ, tolerance))


def classify(estimate: Grid, truth: Grid | PreparedTruth, align, tolerance: int = 0,
             occupied_thresh: float = OCCUPIED_THRESH) -> Overlay:
    """TP/FP/FN masks of `estimate` against `truth` under the transform `align` (estimate ->
    truth: (3,) or {"x", "y", "yaw"}, e.g. score_map(...)["align"]), on the truth's grid
    extended to hold the estimate's occupied cells."""
    t = prepare_truth(truth, occupied_thresh)
    return _overlay(estimate, t, pose_of(align), estimate.occupied_xy(occupied_thresh),
                    int(tolerance), occupied_thresh)


def score_map(estimate: Grid, truth: Grid | PreparedTruth, align: str = "auto",
              initial=(0.0, 0.0, 0.0), tolerance: int = 0,
              occupied_thresh: float = OCCUPIED_THRESH, config: AlignConfig | None = None,
              gtfree: bool = True) -> dict:
    """Score an estimated map against the true map.

    estimate, truth: Grids (any resolution, size and origin; truth may be a PreparedTruth to
    reuse its k-d tree across calls); align: "auto" | "none" | "start" | "icp" | "global";
    initial: (3,) prior transform estimate -> truth (x, y m, yaw rad) or None when unknown;
    tolerance: cells (Chebyshev) within which occupied cells match.
    Returns a dict: precision, sensitivity, f1, tp, fp, fn, tp_truth, tolerance, adnn_cells,
    adnn_m, adnn_reverse_cells, adnn_reverse_m, chamfer_cells, chamfer_m, align {"x","y","yaw"},
    align_mode, align_inlier_fraction, align_rms_m, ssim, occupied_fraction, free_fraction,
    corners, enclosed_areas, est_occupied, true_occupied, and `note` when something is
    undefined (empty estimate: ratios 0, distances NaN).
    Raises InputError when the true map has no occupied cell.
    """
    t = prepare_truth(truth, occupied_thresh)
    est_pts = estimate.occupied_xy(occupied_thresh)
    al = align_points(est_pts, t, align, initial, config or AlignConfig())
    ov = _overlay(estimate, t, al.pose, est_pts, int(tolerance), occupied_thresh)
    out = ov.classes.counts
    out.update(adnn_metrics(transform_points(al.pose, est_pts), t.points, t.tree, t.resolution))
    out.update(align=al.as_dict(), align_mode=al.mode, align_inlier_fraction=al.inlier_fraction,
               align_rms_m=al.rms_m, est_occupied=int(len(est_pts)), true_occupied=int(len(t.points)),
               resolution=t.resolution)
    if gtfree:
        out["ssim"] = ssim(ov.est_prob, ov.true_prob)
        out.update(gtfree_metrics(estimate, occupied_thresh))
    if len(est_pts) == 0:
        out["note"] = ("estimate has no occupied cell: precision, sensitivity and f1 set to 0, "
                       "ADNN undefined (NaN), alignment not refined")
    return out


def save_overlay_png(estimate: Grid, truth: Grid | PreparedTruth, align, path, title: str = "",
                     tolerance: int = 0, occupied_thresh: float = OCCUPIED_THRESH) -> None:
    """Write the TP (green) / FP (red) / FN (yellow) picture of `estimate` against `truth` under
    the transform `align` ((3,) or {"x","y","yaw"}) to the PNG file `path`."""
    from metrics.plot import save_overlay  # matplotlib only when drawing

    save_overlay(classify(estimate, truth, align, tolerance, occupied_thresh), path, title)
