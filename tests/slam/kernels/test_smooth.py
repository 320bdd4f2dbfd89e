"""Angular scan smoothing kernel against its numpy reference."""
import numpy as np
import pytest

from slam._kernels.smooth import smooth_ranges, smooth_ranges_ref


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("circular", [True, False])
def test_kernel_matches_reference(seed, circular):
    rng = np.random.default_rng(seed)
    B = int(rng.integers(20, 400))
    r = rng.uniform(0.2, 3.5, B)
    r[rng.random(B) < 0.3] *= 1.05  # small steps kept, some jumps excluded
    valid = rng.random(B) < 0.9
    half = int(rng.integers(1, 6))
    a = smooth_ranges(np.where(valid, r, 0.0), valid, half, 0.04, 2 * np.pi / B, circular)
    b = smooth_ranges_ref(r, valid, half, 0.04, 2 * np.pi / B, circular)
    np.testing.assert_allclose(a[0][valid], b[0][valid], atol=1e-12)
    np.testing.assert_allclose(a[1][valid], b[1][valid], atol=1e-12)
