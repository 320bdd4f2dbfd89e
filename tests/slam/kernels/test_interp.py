"""Bilinear occupancy interpolation kernel against its reference, and its gradient."""
import numpy as np
import pytest

from slam._kernels.interp import interp_value_grad, interp_value_grad_ref


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(8))
def test_kernel_matches_reference(seed):
    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(5, 30, 2)
    meta = np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), rng.choice([0.05, 0.2]), rows, cols])
    prob = rng.random((rows, cols))
    pts = meta[:2] + rng.uniform(-0.2, 1.2, (300, 2)) * [cols * meta[2], rows * meta[2]]
    np.testing.assert_allclose(interp_value_grad(prob, meta, pts), interp_value_grad_ref(prob, meta, pts),
                               atol=1e-12)


def test_value_at_cell_centre_and_gradient_by_finite_differences(rng):
    prob = rng.random((12, 15))
    meta = np.array([0.3, -0.2, 0.1, 12, 15])
    centre = np.array([[0.3 + 4.5 * 0.1, -0.2 + 7.5 * 0.1]])
    assert interp_value_grad(prob, meta, centre)[0, 0] == pytest.approx(prob[7, 4])
    pts = meta[:2] + rng.uniform(0.1, 1.3, (50, 2))
    h = 1e-6
    out = interp_value_grad(prob, meta, pts)
    for k, d in ((1, [h, 0]), (2, [0, h])):
        fd = (interp_value_grad(prob, meta, pts + d)[:, 0] - interp_value_grad(prob, meta, pts - d)[:, 0]) / (2 * h)
        np.testing.assert_allclose(out[:, k], fd, atol=1e-5)


def test_outside_is_zero():
    prob = np.ones((4, 4))
    meta = np.array([0.0, 0.0, 1.0, 4, 4])
    np.testing.assert_array_equal(interp_value_grad(prob, meta, np.array([[-3.0, 1.0], [9.0, 9.0]])), 0.0)
