"""Grid portion: precision and sensitivity of occupied cells (the reference study's metric).

On the truth's grid, with the estimate resampled onto it after alignment:
TP = estimated occupied and truly occupied, FP = estimated occupied and not truly occupied,
FN = truly occupied and not estimated occupied; precision = TP / (TP + FP) (correctness),
sensitivity = TP / (TP + FN) (completeness), F1 their harmonic mean.

`tolerance` k (cells, Chebyshev distance, i.e. the (2k+1) x (2k+1) square around a cell,
diagonal neighbours included): an estimated occupied cell within k of a true occupied cell is
a TP, and a true occupied cell within k of an estimated one is not an FN. With k > 0 the TP of
precision counts estimated cells and the TP of sensitivity counts the true cells they cover
(`tp_truth`), so that a thick estimated wall cannot make sensitivity exceed 1; with k = 0 the
two are the same number, the study's exact rule.

Empty estimate (no occupied cell): precision, sensitivity and F1 are 0 (not NaN: an empty map
is worthless, and a 0 averages and serialises cleanly) and `note` says so.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from metrics.result import Result

__all__ = ["GridPortion", "Classification", "classify_masks"]

_EMPTY_NOTE = "estimate has no occupied cell: precision, sensitivity and f1 set to 0"


@dataclass(frozen=True)
class GridPortion(Result):
    """Precision, sensitivity and F1 of occupied cells at `tolerance` cells, with their counts."""

    precision: float
    sensitivity: float
    f1: float
    tp: int
    fp: int
    fn: int
    tp_truth: int
    tolerance: int
    note: str | None = None


@dataclass(frozen=True)
class Classification:
    """TP/FP/FN masks (rows, cols) bool on one grid, and the counts and ratios they give."""

    tp: np.ndarray          # estimated occupied cells matched by the truth
    fp: np.ndarray          # estimated occupied cells with no true cell within tolerance
    fn: np.ndarray          # true occupied cells with no estimated cell within tolerance
    tp_truth: int           # true occupied cells matched (= tp count when tolerance == 0)
    tolerance: int

    @property
    def portion(self) -> GridPortion:
        """The counts and ratios of these masks (see the module docstring)."""
        tp, fp, fn = int(self.tp.sum()), int(self.fp.sum()), int(self.fn.sum())
        precision = tp / (tp + fp) if tp + fp else 0.0
        sensitivity = self.tp_truth / (self.tp_truth + fn) if self.tp_truth + fn else 0.0
        f1 = (2 * precision * sensitivity / (precision + sensitivity)
              if precision + sensitivity > 0 else 0.0)
        return GridPortion(float(precision), float(sensitivity), float(f1), tp, fp, fn,
                           int(self.tp_truth), int(self.tolerance),
                           None if tp + fp else _EMPTY_NOTE)

    @property
    def counts(self) -> dict:
        """portion.as_dict(): precision, sensitivity, f1, tp, fp, fn, tp_truth, tolerance."""
        return self.portion.as_dict()


def _grow(mask: np.ndarray, k: int) -> np.ndarray:
    if k <= 0:
        return mask
    return ndimage.binary_dilation(mask, structure=np.ones((2 * k + 1, 2 * k + 1), bool))


def classify_masks(est_occ: np.ndarray, true_occ: np.ndarray, tolerance: int = 0) -> Classification:
    """TP/FP/FN of estimated vs true occupied cells on the same grid.

    est_occ, true_occ: (rows, cols) bool; tolerance: cells (Chebyshev), >= 0.
    """
    est_occ = np.asarray(est_occ, dtype=bool)
    true_occ = np.asarray(true_occ, dtype=bool)
    if est_occ.shape != true_occ.shape:
        raise ValueError(f"classify_masks: shapes differ {est_occ.shape} vs {true_occ.shape}")
    if tolerance < 0 or int(tolerance) != tolerance:
        raise ValueError(f"tolerance must be a non-negative integer, got {tolerance}")
    k = int(tolerance)
    near_true = _grow(true_occ, k)
    near_est = _grow(est_occ, k)
    tp = est_occ & near_true
    fp = est_occ & ~near_true
    fn = true_occ & ~near_est
    tp_truth = int((true_occ & near_est).sum())
    return Classification(tp, fp, fn, tp_truth, k)
