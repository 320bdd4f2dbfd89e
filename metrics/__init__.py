"""Map and trajectory metrics: alignment, grid portion (precision, sensitivity, TP/FP/FN
pictures; the study's cell form and the surface form), ADNN both ways, SSIM and
ground-truth-free map metrics, ATE/RPE, TUM files. Each metric family returns a small frozen
Result dataclass; `metrics.registry` lists the metrics that score_map and the benchmark
compute and report."""
from metrics import registry
from metrics.adnn import Adnn, adnn, adnn_metrics
from metrics.align import MODES, AlignConfig, Alignment, MapAlignment, align_points
from metrics.grid_portion import Classification, GridPortion, classify_masks
from metrics.gtfree import MapQuality, gtfree_metrics, map_quality
from metrics.result import Result
from metrics.score import (MapContext, Overlay, classify, map_context, save_overlay_png,
                           score_context, score_map)
from metrics.ssim import Similarity, ssim
from metrics.surface import (DEFAULT_TAU_M, SurfaceClassification, SurfacePortion,
                             classify_surface, visible_surfaces)
from metrics.trajectory import (TrajectoryContext, TrajectoryError, ate_rpe, rigid_fit_2d,
                                trajectory_error)
from metrics.truth import PreparedTruth, prepare_truth
from sim.logs.tum import read_tum, write_tum
from metrics import builtin as _builtin  # noqa: F401,E402  (registers the built-in metrics)

__all__ = ["score_map", "map_context", "score_context", "MapContext", "classify",
           "save_overlay_png", "Overlay", "trajectory_error", "ate_rpe", "TrajectoryContext",
           "rigid_fit_2d", "read_tum", "write_tum", "align_points", "AlignConfig", "Alignment",
           "MODES", "classify_masks", "Classification", "adnn_metrics", "adnn",
           "gtfree_metrics", "map_quality", "ssim", "prepare_truth", "PreparedTruth",
           "classify_surface", "visible_surfaces", "SurfaceClassification", "DEFAULT_TAU_M",
           "registry", "Result", "GridPortion", "Adnn", "MapAlignment", "Similarity",
           "MapQuality", "SurfacePortion", "TrajectoryError"]
