"""The built-in metrics and the summary.md tables, registered in the order score_map reports
their keys and summary.md shows the tables."""
from __future__ import annotations

from metrics.adnn import Adnn, adnn
from metrics.align import MapAlignment
from metrics.grid_portion import GridPortion
from metrics.gtfree import MapQuality, map_quality
from metrics.registry import Column, Metric, Section, register, register_section
from metrics.result import keys_of
from metrics.ssim import Similarity, ssim
from metrics.surface import SurfacePortion, classify_surface
from metrics.trajectory import TrajectoryError, ate_rpe

__all__: list[str] = []

for _name, _title in (
        ("adnn", "Table 1: ADNN (cells), mean ± std"),
        ("ps", "Table 2: precision (P) and sensitivity (S) of the walls, surface form, "
               "mean ± std"),
        ("ps_cell", "Table 2, the study's cell rule: precision (P) and sensitivity (S) of "
                    "occupied cells, exact cell, mean ± std"),
        ("ps_t1", "Table 2b, the study's cell rule at a tolerance of 1 cell: precision and "
                  "sensitivity"),
        ("ate", "Absolute trajectory error (m, after SE(2) alignment)"),
        ("rpe", "Relative pose error (m per 1 m segment)"),
        ("rtf", "Real-time factor (log duration / wall time; > 1 is faster than real time)")):
    register_section(Section(_name, _title))


def _alignment(ctx) -> MapAlignment:
    al = ctx.alignment
    return MapAlignment(al.as_dict(), al.mode, al.inlier_fraction, al.rms_m,
                        int(len(ctx.est_points)), int(len(ctx.truth.points)),
                        ctx.truth.resolution)


def _surface(ctx) -> SurfacePortion | None:
    """The surface form under its own alignment (the cell form's, refined onto the surfaces:
    MapContext.surface_pose); None for a raster-only truth (or a world with no surface around
    its start)."""
    if ctx.surfaces is None or len(ctx.surfaces) == 0:
        return None
    pose = ctx.alignment.pose if ctx.surface_pose is None else ctx.surface_pose
    return classify_surface(ctx.estimate, ctx.surfaces, pose, ctx.tau_m,
                            ctx.occupied_thresh).portion


def _trajectory(ctx) -> TrajectoryError:
    return ate_rpe(ctx.times, ctx.poses, ctx.gt_t, ctx.gt_poses, ctx.segment_m)


register(Metric(
    "grid_portion", "map", keys_of(GridPortion),
    compute=lambda ctx: ctx.overlay.classes.portion,
    per_tolerance=("precision", "sensitivity", "f1", "tp", "fp", "fn"),
    columns=(
        Column("precision", "precision, study's cell rule", 3, True, section="ps_cell",
               short="P", tolerance=0.03),
        Column("sensitivity", "sensitivity, study's cell rule", 3, True, section="ps_cell",
               short="S", tolerance=0.03),
        Column("f1", "F1, study's cell rule", 3, True),
        Column("precision_t1", "precision, 1 cell", 3, True, section="ps_t1", short="P",
               tolerance=0.03),
        Column("sensitivity_t1", "sensitivity, 1 cell", 3, True, section="ps_t1", short="S",
               tolerance=0.03),
        Column("precision_t2", "precision, 2 cells", 3, True),
        Column("sensitivity_t2", "sensitivity, 2 cells", 3, True))))

# the main precision / sensitivity / F1 of a simulated world; where a truth is only a raster
# (no surfaces) the tables show the cell form's key instead (fallback)
register(Metric(
    "surface", "map", keys_of(SurfacePortion), compute=_surface,
    columns=(
        Column("surface_precision", "precision, surface form", 3, True, section="ps", short="P",
               tolerance=0.03, fallback="precision"),
        Column("surface_sensitivity", "sensitivity, surface form", 3, True, section="ps",
               short="S", tolerance=0.03, fallback="sensitivity"),
        Column("surface_f1", "F1, surface form", 3, True, fallback="f1"))))

register(Metric(
    "adnn", "map", keys_of(Adnn),
    compute=lambda ctx: adnn(ctx.aligned_points, ctx.truth.points, ctx.truth.tree,
                             ctx.truth.resolution),
    columns=(
        Column("adnn_cells", "ADNN (cells)", 2, False, section="adnn", tolerance=0.3),
        Column("adnn_m", "ADNN (m)", 4, False),
        Column("adnn_reverse_cells", "reverse ADNN (cells)", 2, False),
        Column("chamfer_cells", "chamfer (cells)", 2, False))))

register(Metric(
    "alignment", "map", keys_of(MapAlignment), compute=_alignment,
    columns=(
        Column("align_inlier_fraction", "alignment inlier fraction", 3, True),
        Column("align_rms_m", "alignment RMS of the inliers (m)", 4, False))))

register(Metric(
    "ssim", "map", keys_of(Similarity), extra=True,
    compute=lambda ctx: Similarity(ssim(ctx.overlay.est_prob, ctx.overlay.true_prob)),
    columns=(Column("ssim", "SSIM", 3, True),)))

register(Metric(
    "map_quality", "map", keys_of(MapQuality), extra=True,
    compute=lambda ctx: map_quality(ctx.estimate, ctx.occupied_thresh),
    columns=(
        Column("occupied_fraction", "occupied share of known cells", 3),
        Column("free_fraction", "free share of known cells", 3),
        Column("corners", "corners", 1),
        Column("enclosed_areas", "enclosed areas", 1))))

register(Metric(
    "trajectory", "trajectory", keys_of(TrajectoryError), compute=_trajectory,
    columns=(
        Column("ate_m", "ATE (m)", 3, False, section="ate", tolerance=0.02),
        Column("ate_start_m", "ATE from start (m)", 3, False),
        Column("rpe_trans_m", "RPE (m)", 4, False, section="rpe"),
        Column("rpe_rot_rad", "RPE (rad)", 4, False))))

register(Metric(
    "timing", "run", ("wall_time_s", "realtime_factor", "log_duration_s", "scans_processed"),
    columns=(
        Column("realtime_factor", "real-time factor", 1, True, section="rtf"),
        Column("wall_time_s", "wall time (s)", 1, False))))
