"""Grid portion on hand-built 5 x 5 masks with TP/FP/FN counted by hand."""
import numpy as np
import pytest

from metrics.grid_portion import classify_masks


def masks(est_rows, true_rows):
    def m(rows):
        return np.array([[c == "#" for c in r] for r in rows])
    return m(est_rows), m(true_rows)


def test_hand_counted_5x5():
    est, true = masks([".....",
                       "###..",
                       ".....",
                       "..#..",
                       "....#"],
                      [".....",
                       "####.",
                       ".....",
                       ".....",
                       "....."])
    c = classify_masks(est, true).counts
    assert (c["tp"], c["fp"], c["fn"]) == (3, 2, 1)
    assert c["precision"] == pytest.approx(3 / 5)
    assert c["sensitivity"] == pytest.approx(3 / 4)
    assert c["f1"] == pytest.approx(2 * 0.6 * 0.75 / 1.35)


def test_tolerance_one_is_chebyshev():
    # the estimated wall is one row off and one cell diagonal off at the end
    est, true = masks([".....",
                       "###..",
                       ".....",
                       ".....",
                       "....#"],
                      [".....",
                       ".....",
                       "###..",
                       "...#.",
                       "....."])
    exact = classify_masks(est, true, 0).counts
    assert (exact["tp"], exact["fp"], exact["fn"]) == (0, 4, 4)
    one = classify_masks(est, true, 1).counts
    assert (one["tp"], one["fp"], one["fn"]) == (4, 0, 0)
    assert one["precision"] == 1.0 and one["sensitivity"] == 1.0


def test_thick_estimate_cannot_push_sensitivity_above_one():
    est, true = masks([".....",
                       "#####",
                       "#####",
                       "#####",
                       "....."],
                      [".....",
                       ".....",
                       "##...",
                       ".....",
                       "....."])
    c = classify_masks(est, true, 1).counts
    assert c["tp_truth"] == 2 and c["fn"] == 0 and c["sensitivity"] == 1.0
    assert c["tp"] == 9 and c["fp"] == 6  # the 3 x 3 block around the two true cells


def test_empty_estimate_is_defined_and_says_so():
    est = np.zeros((5, 5), bool)
    true = np.eye(5, dtype=bool)
    c = classify_masks(est, true).counts
    assert c["precision"] == 0.0 and c["sensitivity"] == 0.0 and c["f1"] == 0.0
    assert c["fn"] == 5 and "no occupied cell" in c["note"]


def test_bad_arguments():
    with pytest.raises(ValueError):
        classify_masks(np.zeros((2, 2), bool), np.zeros((3, 3), bool))
    with pytest.raises(ValueError):
        classify_masks(np.zeros((2, 2), bool), np.zeros((2, 2), bool), tolerance=-1)
