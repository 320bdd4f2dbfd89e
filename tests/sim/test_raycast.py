import numpy as np
import pytest

from sim._raycast import cast_rays, cast_rays_indexed, cast_rays_ref, segment_grid
from tests.sim.worlds_fixtures import square_room


def _assert_matches_ref(got, want):
    """Misses (inf) in the same rays, and the hit distances equal to 1e-12 m."""
    assert np.array_equal(np.isinf(got), np.isinf(want))
    fin = np.isfinite(want)
    np.testing.assert_allclose(got[fin], want[fin], rtol=1e-12, atol=1e-12)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_matches_reference(seed):
    rng = np.random.default_rng(seed)
    segs = rng.uniform(-3, 3, (60, 4))
    origins = rng.uniform(-1, 1, (500, 2))
    angles = rng.uniform(-np.pi, np.pi, 500)
    for max_range in (1.0, 3.5, np.inf):
        _assert_matches_ref(cast_rays(segs, origins, angles, max_range),
                            cast_rays_ref(segs, origins, angles, max_range))


@pytest.mark.kernel
def test_kernel_matches_reference_on_world_segments():
    segs = square_room().segments
    rng = np.random.default_rng(3)
    origins = rng.uniform(0.2, 3.8, (300, 2))
    angles = rng.uniform(0, 2 * np.pi, 300)
    np.testing.assert_allclose(cast_rays(segs, origins, angles, 3.5),
                               cast_rays_ref(segs, origins, angles, 3.5))


@pytest.mark.kernel
def test_no_segments_and_parallel_rays():
    o = np.zeros((2, 2))
    a = np.array([0.0, np.pi / 2])
    assert np.isinf(cast_rays(np.zeros((0, 4)), o, a, 5.0)).all()
    assert np.isinf(cast_rays_ref(np.zeros((0, 4)), o, a, 5.0)).all()
    # a segment parallel to beam 0, and crossed by beam 1 at distance 1
    seg = np.array([[-1.0, 1.0, 1.0, 1.0]])
    for f in (cast_rays, cast_rays_ref):
        r = f(seg, o, a, 5.0)
        assert np.isinf(r[0]) and r[1] == pytest.approx(1.0)


def test_hand_computed_distances_in_a_unit_box():
    seg = np.array([[0, 0, 2, 0], [2, 0, 2, 2], [2, 2, 0, 2], [0, 2, 0, 0]], float)
    o = np.array([[0.5, 1.0]] * 4)
    a = np.array([0, np.pi / 2, np.pi, np.pi / 4])
    r = cast_rays(seg, o, a, 10.0)
    np.testing.assert_allclose(r, [1.5, 1.0, 0.5, np.sqrt(2)], atol=1e-12)
    assert np.isinf(cast_rays(seg, o, a, 0.9)[[0, 1, 3]]).all()


def _random_scene(seed):
    """Segments of every kind (axis-aligned, slanted, tiny, long) and rays from inside and
    outside the segments' box, some on the grid's cell edges and corners."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-3, 3, (40, 2))
    segs = np.vstack([
        np.c_[a, a + rng.uniform(-2, 2, (40, 2))],                       # slanted
        np.c_[a[:10], a[:10, 0] + rng.uniform(-3, 3, 10), a[:10, 1]],    # horizontal
        np.c_[a[10:20], a[10:20, 0], a[10:20, 1] + rng.uniform(-3, 3, 10)],  # vertical
        np.c_[a[20:25], a[20:25] + 1e-4],                                # tiny
        [[-6.0, -6.0, 6.0, 6.0], [-6.0, 5.0, 6.0, -5.0]],                # long diagonals
    ])
    origins = np.vstack([rng.uniform(-4, 4, (400, 2)), rng.uniform(-12, 12, (200, 2)),
                         np.round(rng.uniform(-4, 4, (100, 2)) * 2) / 2])  # on 0.5 m edges
    angles = np.r_[rng.uniform(-np.pi, np.pi, 600), np.arange(100) * (np.pi / 4)]
    return segs, origins, angles


@pytest.mark.kernel
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("cell", [0.05, 0.5, 3.0])
def test_indexed_kernel_equals_brute_force_bit_for_bit(seed, cell):
    segs, origins, angles = _random_scene(seed)
    grid = segment_grid(segs, cell)
    for max_range in (1.0, 3.5, np.inf):
        got = cast_rays_indexed(segs, *grid, origins, angles, max_range)
        assert np.array_equal(got, cast_rays(segs, origins, angles, max_range))
        _assert_matches_ref(got, cast_rays_ref(segs, origins, angles, max_range))


@pytest.mark.kernel
def test_indexed_kernel_on_world_segments_and_without_segments():
    segs = square_room().segments
    rng = np.random.default_rng(4)
    origins = rng.uniform(0.2, 3.8, (300, 2))
    angles = rng.uniform(0, 2 * np.pi, 300)
    got = cast_rays_indexed(segs, *segment_grid(segs, 0.5), origins, angles, 3.5)
    np.testing.assert_array_equal(got, cast_rays(segs, origins, angles, 3.5))
    np.testing.assert_allclose(got, cast_rays_ref(segs, origins, angles, 3.5))
    empty = np.zeros((0, 4))
    assert np.isinf(cast_rays_indexed(empty, *segment_grid(empty, 0.5), origins, angles, np.inf)).all()


def test_segment_grid_files_each_segment_in_the_cells_it_crosses():
    segs, _, _ = _random_scene(5)
    meta, start, items = segment_grid(segs, 0.3)
    x0, y0, cell, cols, rows = meta
    f = np.linspace(0, 1, 2001)[:, None]
    for s, (ax, ay, bx, by) in enumerate(segs):
        pts = np.c_[ax + f * (bx - ax), ay + f * (by - ay)]
        c = np.floor((pts[:, 0] - x0) / cell).astype(int)
        r = np.floor((pts[:, 1] - y0) / cell).astype(int)
        assert (c >= 0).all() and (c < cols).all() and (r >= 0).all() and (r < rows).all()
        for k in np.unique(r * int(cols) + c):
            assert s in items[start[k]:start[k + 1]]
    with pytest.raises(ValueError):
        segment_grid(segs, 0.0)
