"""Map and trajectory metrics: alignment, grid portion (precision, sensitivity, TP/FP/FN
pictures; the study's cell form and the surface form), ADNN both ways, SSIM and
ground-truth-free map metrics, ATE/RPE, TUM files."""
from metrics.adnn import adnn_metrics
from metrics.align import MODES, AlignConfig, Alignment, align_points
from metrics.grid_portion import Classification, classify_masks
from metrics.gtfree import gtfree_metrics
from metrics.score import Overlay, classify, save_overlay_png, score_map
from metrics.ssim import ssim
from metrics.surface import DEFAULT_TAU_M, SurfaceClassification, classify_surface, visible_surfaces
from metrics.trajectory import rigid_fit_2d, trajectory_error
from metrics.truth import PreparedTruth, prepare_truth
from metrics.tum import read_tum, write_tum

__all__ = ["score_map", "classify", "save_overlay_png", "Overlay", "trajectory_error",
           "rigid_fit_2d", "read_tum", "write_tum", "align_points", "AlignConfig", "Alignment",
           "MODES", "classify_masks", "Classification", "adnn_metrics", "gtfree_metrics", "ssim",
           "prepare_truth", "PreparedTruth", "classify_surface", "visible_surfaces",
           "SurfaceClassification", "DEFAULT_TAU_M"]
