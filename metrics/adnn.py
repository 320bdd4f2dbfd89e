"""ADNN: average distance to the nearest neighbour between occupied cells of two maps.

ADNN (as in the reference study): mean distance from each estimated occupied cell centre,
after alignment, to the nearest true occupied cell centre. It ignores missing walls, so the
reverse direction (each true cell to the nearest estimated cell) is reported too, and their
mean (the symmetric chamfer distance). Distances are measured between the continuous cell
centres (no resampling), in metres and in true-map cells.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["adnn_metrics"]


def adnn_metrics(est_points: np.ndarray, true_points: np.ndarray, true_tree: cKDTree | None,
                 resolution: float) -> dict:
    """ADNN both ways between estimated (N, 2) and true (M, 2) occupied cell centres, world m.

    est_points must already be aligned to the truth; true_tree: cKDTree of true_points (built
    when None); resolution: m per cell of the true map. Returns adnn_m, adnn_cells,
    adnn_reverse_m, adnn_reverse_cells, chamfer_m, chamfer_cells; all NaN when there is no
    estimated point (the distances are undefined).
    """
    est_points = np.asarray(est_points, dtype=np.float64).reshape(-1, 2)
    true_points = np.asarray(true_points, dtype=np.float64).reshape(-1, 2)
    if len(est_points) == 0 or len(true_points) == 0:
        nan = float("nan")
        fwd = rev = nan
    else:
        tree = true_tree if true_tree is not None else cKDTree(true_points)
        fwd = float(tree.query(est_points)[0].mean())
        rev = float(cKDTree(est_points).query(true_points)[0].mean())
    cham = 0.5 * (fwd + rev)
    return {"adnn_m": fwd, "adnn_cells": fwd / resolution,
            "adnn_reverse_m": rev, "adnn_reverse_cells": rev / resolution,
            "chamfer_m": cham, "chamfer_cells": cham / resolution}
