"""Log-odds to probability kernel against its numpy reference."""
import numpy as np
import pytest

from slam._kernels.prob import logodds_to_prob, logodds_to_prob_ref


@pytest.mark.kernel
def test_logodds_to_prob_matches_reference_and_fills_unknown():
    rng = np.random.default_rng(0)
    lo = rng.normal(0, 5, (37, 23))
    lo[rng.random(lo.shape) < 0.3] = np.nan
    lo[0, 0], lo[0, 1] = 60.0, -60.0
    for unknown in (0.5, 0.1, np.nan):
        p = logodds_to_prob(lo, unknown)
        np.testing.assert_allclose(p, logodds_to_prob_ref(lo, unknown), rtol=1e-14, equal_nan=True)
    p = logodds_to_prob(lo, 0.1)
    assert np.all(p[np.isnan(lo)] == 0.1)
    assert p[0, 0] == 1.0 and 0.0 < p[0, 1] < 1e-20
