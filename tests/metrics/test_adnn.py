"""ADNN both ways on point sets with distances known by hand."""
import numpy as np
import pytest

from metrics.adnn import adnn_metrics

RES = 0.05


def wall(n, y=0.0):
    return np.stack([np.arange(n) * RES, np.full(n, y)], axis=1)


def test_identical_is_zero():
    p = wall(20)
    r = adnn_metrics(p, p, None, RES)
    assert r["adnn_m"] == 0.0 and r["adnn_reverse_m"] == 0.0 and r["chamfer_cells"] == 0.0


def test_parallel_shift_by_one_cell():
    r = adnn_metrics(wall(20, RES), wall(20), None, RES)
    assert r["adnn_cells"] == pytest.approx(1.0)
    assert r["adnn_reverse_cells"] == pytest.approx(1.0)
    assert r["adnn_m"] == pytest.approx(RES)


def test_missing_half_hides_from_forward_but_not_reverse():
    true = wall(20)
    est = true[:10]
    r = adnn_metrics(est, true, None, RES)
    assert r["adnn_m"] == 0.0
    # true cells 10..19 lie 1..10 cells from the last estimated cell (index 9)
    assert r["adnn_reverse_cells"] == pytest.approx(np.arange(1, 11).sum() / 20)
    assert r["chamfer_cells"] == pytest.approx(0.5 * r["adnn_reverse_cells"])


def test_no_estimate_points_gives_nan():
    r = adnn_metrics(np.zeros((0, 2)), wall(5), None, RES)
    assert np.isnan(r["adnn_m"]) and np.isnan(r["adnn_reverse_cells"])
