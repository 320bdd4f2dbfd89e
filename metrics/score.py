"""score_map: every map metric of one estimated map against the true map, in one call.

Steps: occupied cell centres of the estimate -> alignment (align.py) -> the estimate resampled
onto the truth's grid, extended to hold all of it (resample.py) -> a MapContext holding these
-> every registered map metric (metrics.registry, in registration order: TP/FP/FN, ADNN both
ways, the surface form when the world's surfaces are given (under the alignment refined onto
those surfaces, align.refine_to_surfaces), the alignment used, SSIM and
the ground-truth-free metrics of the estimate).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from metrics import registry
from metrics.align import AlignConfig, Alignment, align_points, refine_to_surfaces
from metrics.grid_portion import Classification, classify_masks
from metrics.resample import extended_grid, resample_onto
from metrics.surface import DEFAULT_TAU_M
from metrics.truth import PreparedTruth, prepare_truth
from slam.pose import transform_points
from worlds.grid import OCCUPIED_THRESH, Grid

__all__ = ["score_map", "map_context", "score_context", "MapContext", "classify", "Overlay",
           "save_overlay_png", "pose_of"]

_EMPTY_NOTE = ("estimate has no occupied cell: precision, sensitivity and f1 set to 0, "
               "ADNN undefined (NaN), alignment not refined")


@dataclass(frozen=True)
class Overlay:
    """The estimate on the (extended) truth grid: `grid` geometry, estimate probabilities
    `est_prob` (rows, cols), true probabilities `true_prob` and the TP/FP/FN classification."""

    grid: Grid
    est_prob: np.ndarray
    true_prob: np.ndarray
    classes: Classification


@dataclass(frozen=True)
class MapContext:
    """What a map metric reads: the estimate, the prepared truth, the alignment, the estimate's
    occupied cell centres (N, 2) in its own frame and aligned to the truth (world m), the
    overlay on the truth's grid, classified at `overlay.classes.tolerance` cells, and the
    world's visible surfaces (S, 4) x0, y0, x1, y1 m with the surface form's tolerance tau_m
    (m) and the surface form's alignment surface_pose (3,) (the alignment refined onto the
    surfaces when it was searched, as given otherwise); surfaces None: the truth is only a
    raster, the surface form does not apply."""

    estimate: Grid
    truth: PreparedTruth
    alignment: Alignment
    est_points: np.ndarray
    aligned_points: np.ndarray
    overlay: Overlay
    occupied_thresh: float
    surfaces: np.ndarray | None = None
    tau_m: float = DEFAULT_TAU_M
    surface_pose: np.ndarray | None = None   # the surface form's alignment (align.refine_to_surfaces)

    def at_tolerance(self, tolerance: int) -> MapContext:
        """The same context with the overlay classified at `tolerance` cells."""
        ov = _overlay(self.estimate, self.truth, self.alignment.pose, self.est_points,
                      int(tolerance), self.occupied_thresh)
        return replace(self, overlay=ov)


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


def map_context(estimate: Grid, truth: Grid | PreparedTruth, align: str = "auto",
                initial=(0.0, 0.0, 0.0), tolerance: int = 0,
                occupied_thresh: float = OCCUPIED_THRESH,
                config: AlignConfig | None = None, surfaces: np.ndarray | None = None,
                tau_m: float = DEFAULT_TAU_M) -> MapContext:
    """Align `estimate` to `truth` and build the MapContext the map metrics read (arguments
    as score_map's)."""
    t = prepare_truth(truth, occupied_thresh)
    est_pts = estimate.occupied_xy(occupied_thresh)
    al = align_points(est_pts, t, align, initial, config or AlignConfig())
    ov = _overlay(estimate, t, al.pose, est_pts, int(tolerance), occupied_thresh)
    surface_pose = None
    if surfaces is not None:
        surfaces = np.asarray(surfaces, dtype=np.float64).reshape(-1, 4)
        surface_pose = al.pose
        if al.mode in ("icp", "global"):
            surface_pose, _ = refine_to_surfaces(est_pts, surfaces, al.pose, estimate.resolution,
                                                 config or AlignConfig(), estimate.origin[2])
    return MapContext(estimate, t, al, est_pts, transform_points(al.pose, est_pts), ov,
                      occupied_thresh, surfaces, float(tau_m), surface_pose)


def score_context(ctx: MapContext, gtfree: bool = True) -> dict:
    """Every registered map metric of `ctx` as one flat dict (gtfree=False skips the metrics
    registered as extra: SSIM and the ground-truth-free ones)."""
    out = registry.compute("map", ctx, extra=gtfree)
    if len(ctx.est_points) == 0:
        out["note"] = _EMPTY_NOTE
    return out


def score_map(estimate: Grid, truth: Grid | PreparedTruth, align: str = "auto",
              initial=(0.0, 0.0, 0.0), tolerance: int = 0,
              occupied_thresh: float = OCCUPIED_THRESH, config: AlignConfig | None = None,
              gtfree: bool = True, surfaces: np.ndarray | None = None,
              tau_m: float = DEFAULT_TAU_M) -> dict:
    """Score an estimated map against the true map.

    estimate, truth: Grids (any resolution, size and origin; truth may be a PreparedTruth to
    reuse its k-d tree across calls); align: "auto" | "none" | "start" | "icp" | "global";
    initial: (3,) prior transform estimate -> truth (x, y m, yaw rad) or None when unknown;
    tolerance: cells (Chebyshev) within which occupied cells match; surfaces: the world's
    visible surfaces (S, 4) x0, y0, x1, y1 m (metrics.surface.visible_surfaces) for the
    surface form at tau_m metres under the same alignment, None for a truth that is only a
    raster (then no surface_* keys).
    Returns a dict: precision, sensitivity, f1, tp, fp, fn, tp_truth, tolerance (the study's
    cell rule), surface_precision, surface_sensitivity, surface_f1, surface_tp, surface_fp,
    surface_length_m, surface_covered_m, surface_tau_m (with surfaces), adnn_m,
    adnn_cells, adnn_reverse_m, adnn_reverse_cells, chamfer_m, chamfer_cells, align
    {"x","y","yaw"}, align_mode, align_inlier_fraction, align_rms_m, est_occupied,
    true_occupied, resolution, ssim, occupied_fraction, free_fraction, corners,
    enclosed_areas, then the keys of any other registered map metric, and `note` when
    something is undefined (empty estimate: ratios 0, distances NaN).
    Raises InputError when the true map has no occupied cell.
    """
    ctx = map_context(estimate, truth, align, initial, tolerance, occupied_thresh, config,
                      surfaces, tau_m)
    return score_context(ctx, gtfree)


def save_overlay_png(estimate: Grid, truth: Grid | PreparedTruth, align, path, title: str = "",
                     tolerance: int = 0, occupied_thresh: float = OCCUPIED_THRESH) -> None:
    """Write the TP (green) / FP (red) / FN (yellow) picture of `estimate` against `truth` under
    the transform `align` ((3,) or {"x","y","yaw"}) to the PNG file `path`."""
    from metrics.plot import save_overlay  # matplotlib only when drawing

    save_overlay(classify(estimate, truth, align, tolerance, occupied_thresh), path, title)
