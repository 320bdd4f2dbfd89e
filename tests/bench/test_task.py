import numpy as np

from bench.task import check_divergence


def test_divergence_rules():
    b = (0.0, 0.0, 3.0, 2.0)
    ok = np.array([[0.5, 0.5, 0.0], [4.9, 3.9, 1.0], [-1.9, -1.9, 0.0]])
    assert check_divergence(ok, b) is None
    assert "non-finite pose at index 1" in check_divergence(np.array([[0, 0, 0], [np.nan, 0, 0]]), b)
    msg = check_divergence(np.array([[0, 0, 0], [5.1, 0, 0]]), b)
    assert msg.startswith("diverged: pose 1") and "2 m outside" in msg
    assert "empty" in check_divergence(np.zeros((0, 3)), b)
