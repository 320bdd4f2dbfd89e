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


@pytest.mark.parametrize("randomized", [False, True])
@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("size", [0.0, 0.025, 0.05, 0.37, 2.0])
def test_voxel_filter_equals_reference(seed, size, randomized):
    pts = _cloud(np.random.default_rng(seed), 400)
    np.testing.assert_array_equal(voxel_filter(pts, size, randomized), voxel_filter_ref(pts, size, randomized))


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("max_length, min_points, max_range",
                         [(0.5, 200, 50.0), (0.9, 100, 50.0), (0.5, 200, 3.0), (0.5, 500, 50.0),
                          (0.5, 10, 2.0)])
@pytest.mark.parametrize("randomized", [False, True])
def test_adaptive_voxel_filter_equals_reference(seed, max_length, min_points, max_range, randomized):
    pts = _cloud(np.random.default_rng(seed), 400)
    got = adaptive_voxel_filter(pts, max_length, min_points, max_range, randomized)
    np.testing.assert_array_equal(got, adaptive_voxel_filter_ref(pts, max_length, min_points, max_range,
                                                                 randomized))
    if len(got) < np.sum(np.hypot(*pts.T) <= max_range):
        assert len(got) >= min_points


def test_empty_and_tiny_inputs():
    empty = np.zeros((0, 2))
    assert voxel_filter(empty, 0.05).shape == (0, 2)
    assert adaptive_voxel_filter(empty, 0.5, 200, 50.0).shape == (0, 2)
    one = np.array([[0.3, -0.2]])
    np.testing.assert_array_equal(adaptive_voxel_filter(one, 0.5, 200, 50.0), one)


@pytest.mark.parametrize("randomized, expected", [(False, 0.0), (True, 0.5)])
def test_randomized_voxel_filter_keeps_one_point_per_voxel_drawn_evenly(randomized, expected):
    # points 1 mm apart along a line in scan order: the first-point filter keeps every voxel's
    # first point (offset 0 in the voxel), the randomized one a point spread over the voxel
    size = 0.025
    x = np.arange(0.0005, 4.0, 0.001)
    pts = np.column_stack([x, np.full_like(x, 0.0101)])
    kept = voxel_filter(pts, size, randomized)
    assert len(kept) == len(np.unique(np.floor(x / size)))
    offset = (kept[:, 0] % size) / size
    assert abs(offset.mean() - expected) < 0.06
    np.testing.assert_array_equal(kept, voxel_filter(pts, size, randomized))   # reproducible
