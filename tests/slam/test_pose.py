"""SE(2) algebra: the one-pose fast paths agree with the batched formulas."""
import math

import numpy as np

from slam.pose import compose, inverse, relative, wrap_angle


def test_single_pose_paths_match_batched_rows():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(500, 3)) * [5, 5, 4]
    b = rng.normal(size=(500, 3)) * [5, 5, 4]
    batched = compose(a, b), inverse(a), relative(a, b)
    for k in range(len(a)):
        np.testing.assert_allclose(compose(a[k], b[k]), batched[0][k], atol=1e-12)
        np.testing.assert_allclose(inverse(a[k]), batched[1][k], atol=1e-12)
        np.testing.assert_allclose(relative(a[k], b[k]), batched[2][k], atol=1e-12)
    np.testing.assert_allclose(compose(a[0], inverse(a[0])), [0, 0, 0], atol=1e-12)


def test_wrap_angle_scalar_and_array_agree_on_the_boundary():
    for v in (-math.pi, math.pi, 3 * math.pi, -3 * math.pi, 0.0, 7.0, np.float64(-math.pi)):
        s = wrap_angle(v)
        assert isinstance(s, float)
        assert s == wrap_angle(np.array([v]))[0]
        assert -math.pi < s <= math.pi
