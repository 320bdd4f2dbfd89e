"""Surface form of the grid portion: precision and sensitivity against the wall surfaces.

For simulated worlds the exact geometry is known, so the truth need not be a raster:
 - the visible surfaces are the boundary rings of the free space around the start
   (World.free_space, the surfaces worlds.raster marks) as segments;
 - an estimated occupied cell is a true positive when its closed square, grown by tau
   metres, touches a visible surface (the distance between square and surface <= tau);
 - precision = true-positive cells / occupied cells;
 - sensitivity = the share of the surfaces' length within tau of some occupied cell's square.
The study's exact rule asks an occupied cell to be a true wall cell, and a true wall cell to
be occupied; here a face on a cell edge belongs to both cells beside it and a surface that
clips a cell's corner weighs by the length it runs through the cell, so the score does not
depend on where the walls sit on the grid. The estimate is read on its own cells: the
surfaces are moved into its frame by the inverse of the alignment.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from metrics._surface_kernel import surface_match
from metrics.result import Result
from slam.pose import inverse, transform_points
from worlds.grid import OCCUPIED_THRESH, Grid

__all__ = ["visible_surfaces", "SurfacePortion", "SurfaceClassification", "classify_surface",
           "DEFAULT_TAU_M"]

# tolerance of the surface form (m), a tenth of a 0.05 m cell: the output map draws a wall in
# the cell that holds its surface, so the oracle's maps (true poses, realistic noise) need no
# slack beyond the range noise left after averaging (P and S >= 0.96 on 144 maps, mean
# 0.995 / 0.991), while a map one cell off scores about 0.1 (tools/surface_metric.py)
DEFAULT_TAU_M = 0.005
# a face exactly on a cell edge must touch both cells despite floating-point rounding of the
# transform into map coordinates: a tolerance this small (cells, 5e-8 m) is added to tau
_EDGE_EPS_CELLS = 1e-6


def visible_surfaces(world) -> np.ndarray:
    """(S, 4) x0, y0, x1, y1 (m): the boundary of the free space around the start, i.e. every
    wall and obstacle surface a lidar on the robot can see (World.visible_segments)."""
    return world.visible_segments


@dataclass(frozen=True)
class SurfacePortion(Result):
    """The surface form's precision, sensitivity and F1, cell counts, surface lengths (m) and
    the alignment {"x", "y", "yaw"} it was scored under."""

    surface_precision: float
    surface_sensitivity: float
    surface_f1: float
    surface_tp: int
    surface_fp: int
    surface_length_m: float
    surface_covered_m: float
    surface_tau_m: float
    surface_align: dict        # the transform estimate -> world it was scored under


@dataclass(frozen=True)
class SurfaceClassification:
    """The surface form of one estimate: its occupied cells, which of them touch a surface,
    the surfaces (world frame) and their covered parameter intervals."""

    grid: Grid                 # the estimate's grid (cells are read there)
    rows: np.ndarray           # (N,) occupied cells of the estimate
    cols: np.ndarray
    tp: np.ndarray             # (N,) bool: within tau of a surface
    segments: np.ndarray       # (S, 4) visible surfaces, world frame (m)
    intervals: np.ndarray      # (M, 3) segment index, t0, t1 of the covered stretches
    tau_m: float
    pose: np.ndarray           # alignment estimate -> world, (3,)

    @property
    def portion(self) -> SurfacePortion:
        """Precision, sensitivity, F1 and lengths of this classification."""
        seg_len = np.hypot(self.segments[:, 2] - self.segments[:, 0],
                           self.segments[:, 3] - self.segments[:, 1])
        total = float(seg_len.sum())
        covered = 0.0
        if len(self.intervals):
            idx = self.intervals[:, 0].astype(np.int64)
            covered = float(np.sum((self.intervals[:, 2] - self.intervals[:, 1]) * seg_len[idx]))
        tp = int(self.tp.sum())
        n = len(self.tp)
        precision = tp / n if n else 0.0
        sensitivity = covered / total if total > 0 else 0.0
        f1 = (2 * precision * sensitivity / (precision + sensitivity)
              if precision + sensitivity > 0 else 0.0)
        align = {"x": float(self.pose[0]), "y": float(self.pose[1]), "yaw": float(self.pose[2])}
        return SurfacePortion(float(precision), float(sensitivity), float(f1), tp, n - tp, total,
                              covered, float(self.tau_m), align)

    @property
    def counts(self) -> dict:
        """portion.as_dict(): surface_precision, surface_sensitivity, surface_f1, surface_tp,
        surface_fp, surface_length_m, surface_covered_m, surface_tau_m, surface_align."""
        return self.portion.as_dict()

    def fp_xy(self) -> np.ndarray:
        """(K, 2) world centres of the false-positive cells."""
        return self._centres(~self.tp)

    def tp_xy(self) -> np.ndarray:
        """(K, 2) world centres of the true-positive cells."""
        return self._centres(self.tp)

    def _centres(self, mask: np.ndarray) -> np.ndarray:
        centres = self.grid.cell_to_world(self.rows[mask], self.cols[mask])
        return transform_points(self.pose, centres)


def classify_surface(estimate: Grid, segments: np.ndarray, align=(0.0, 0.0, 0.0),
                     tau_m: float = DEFAULT_TAU_M,
                     occupied_thresh: float = OCCUPIED_THRESH) -> SurfaceClassification:
    """The surface form of `estimate` against the surfaces `segments` ((S, 4) m, world frame,
    e.g. visible_surfaces(world)) under the transform `align` (estimate -> world, (3,) x, y,
    yaw). tau_m: tolerance in metres (>= 0)."""
    if not tau_m >= 0:
        raise ValueError(f"tau must be >= 0 m, got {tau_m}")
    pose = np.asarray(align, dtype=np.float64).reshape(3)
    segments = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    inv = inverse(pose)
    ends = np.vstack([segments[:, :2], segments[:, 2:]])
    m = estimate.world_to_map(transform_points(inv, ends))
    segs_map = np.hstack([m[:len(segments)], m[len(segments):]])
    occupied = estimate.occupied(occupied_thresh)
    d = tau_m / estimate.resolution + _EDGE_EPS_CELLS
    tp_mask, intervals = surface_match(segs_map, occupied, d)
    rows, cols = np.nonzero(occupied)
    return SurfaceClassification(estimate, rows, cols, tp_mask[rows, cols], segments,
                                 intervals, float(tau_m), pose)
