"""ADNN: average distance to the nearest neighbour between occupied cells of two maps.

ADNN (as in the reference study): mean distance from each estimated occupied cell centre,
after alignment, to the nearest true occupied cell centre. It ignores missing walls, so the
reverse direction (each true cell to the nearest estimated cell) is reported too, and their
mean (the symmetric chamfer distance). Distances are measured between the continuous cell
centres (no resampling), in metres and in true-map cells.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from metrics.result import Result

__all__ = ["Adnn", "adnn", "adnn_metrics"]


@dataclass(frozen=True)
class Adnn(Result):
    """ADNN estimate -> truth, reverse ADNN truth -> estimate and their mean (chamfer), in m and
    in true-map cells; NaN when undefined."""

    adnn_m: float
    adnn_cells: float
    adnn_reverse_m: float
    adnn_reverse_cells: float
    chamfer_m: float
    chamfer_cells: float


def adnn(est_points: np.ndarray, true_points: np.ndarray, true_tree: cKDTree | None,
         resolution: float) -> Adnn:
    """ADNN both ways between estimated (N, 2) and true (M, 2) occupied cell centres, world m.

    est_points must already be aligned to the truth; true_tree: cKDTree of true_points (built
    when None); resolution: m per cell of the true map. All NaN when there is no estimated
    point (the distances are undefined).
    """
    est_points = np.asarray(est_points, dtype=np.float64).reshape(-1, 2)
    true_points = np.asarray(true_points, dtype=np.float64).reshape(-1, 2)
    if len(est_points) == 0 or len(true_points) == 0:
        fwd = rev = float("nan")
    else:
        tree = true_tree if true_tree is not None else cKDTree(true_points)
        fwd = float(tree.query(est_points)[0].mean())
        rev = float(cKDTree(est_points).query(true_points)[0].mean())
    cham = 0.5 * (fwd + rev)
    return Adnn(fwd, fwd / resolution, rev, rev / resolution, cham, cham / resolution)


def adnn_metrics(est_points: np.ndarray, true_points: np.ndarray, true_tree: cKDTree | None,
                 resolution: float) -> dict:
    """adnn(...).as_dict(): adnn_m, adnn_cells, adnn_reverse_m, adnn_reverse_cells, chamfer_m,
    chamfer_cells."""
    return adnn(est_points, true_points, true_tree, resolution).as_dict()
