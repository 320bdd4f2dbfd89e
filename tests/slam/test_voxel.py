"""Voxel filters: the compiled kernels equal the plain-numpy references."""
import numpy as np
import pytest

from slam.graph.filters import (adaptive_voxel_filter, adaptive_voxel_filter_ref, voxel_filter,
                                voxel_filter_ref)

pytestmark = pytest.mark.kernel


def _cloud(rng, n):
    # a scan-like cloud: walls (many points per voxel) plus scattered points, some far away
    t = rng.uniform(0, 2 * np.pi, n)
    r = rng.choice([0.8, 1.5, 3.2, 12.0], n) + rng.normal(0, 0.02, n)
    return np.column_stack([r * np.cos(t), r * np.sin(t)])


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("size", [0.0, 0.025, 0.05, 0.37, 2.0])
def test_voxel_filter_equals_reference(seed, size):
    pts = _cloud(np.random.default_rng(seed), 400)
    np.testing.assert_array_equal(voxel_filter(pts, size), voxel_filter_ref(pts, size))


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("max_length, min_points, max_range",
                         [(0.5, 200, 50.0), (0.9, 100, 50.0), (0.5, 200, 3.0), (0.5, 500, 50.0),
                          (0.5, 10, 2.0)])
def test_adaptive_voxel_filter_equals_reference(seed, max_length, min_points, max_range):
    pts = _cloud(np.random.default_rng(seed), 400)
    got = adaptive_voxel_filter(pts, max_length, min_points, max_range)
    np.testing.assert_array_equal(got, adaptive_voxel_filter_ref(pts, max_length, min_points, max_range))
    if len(got) < np.sum(np.hypot(*pts.T) <= max_range):
        assert len(got) >= min_points


def test_empty_and_tiny_inputs():
    empty = np.zeros((0, 2))
    assert voxel_filter(empty, 0.05).shape == (0, 2)
    assert adaptive_voxel_filter(empty, 0.5, 200, 50.0).shape == (0, 2)
    one = np.array([[0.3, -0.2]])
    np.testing.assert_array_equal(adaptive_voxel_filter(one, 0.5, 200, 50.0), one)
