"""TSDF submaps of `graph`: the kernels against their references, the surface they recover, the
submap interface the matchers read, and scan matching on them."""
import numpy as np
import pytest

from slam.graph._tsdf_kernel import (cells_under, cells_under_ref, estimate_normals, estimate_normals_ref, tsdf_insert,
                                    tsdf_insert_ref)
from slam.graph.config import CeresScanMatcherConfig, SubmapsConfig, TsdfInserterConfig
from slam.graph.scan_matching import ceres_match
from slam.graph.submaps import ActiveSubmaps, Submap
from slam.graph.tsdf import TsdfGrid, TsdfSubmap
from slam.pose import transform_points


def _wall_scan(origin, y_wall, n=120, noise=0.0, rng=None):
    """Hits of a lidar at origin (2,) on the horizontal wall y = y_wall, bearing order."""
    bearings = np.linspace(np.radians(20), np.radians(160), n)
    if y_wall < origin[1]:
        bearings = -bearings[::-1]
    r = (y_wall - origin[1]) / np.sin(bearings)
    if noise:
        r = r + rng.normal(0, noise, n)
    return origin + np.column_stack([r * np.cos(bearings), r * np.sin(bearings)])


def _scan_cloud(rng, n=200):
    # a closed room with a pillar, seen from near its centre: neighbours within and beyond the radius
    t = np.sort(rng.uniform(-np.pi, np.pi, n))
    r = np.where(np.abs(t) < 0.4, 0.9, 2.5 + 0.8 * np.cos(3 * t)) + rng.normal(0, 0.01, n)
    return np.column_stack([r * np.cos(t), r * np.sin(t)]) + [0.3, -0.2]


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("samples, radius", [(4, 0.5), (10, 0.5), (10, 0.05), (1, 0.5)])
def test_scan_normals_equal_reference(seed, samples, radius):
    rng = np.random.default_rng(seed)
    hits = _scan_cloud(rng)
    origin = np.array([0.3, -0.2])
    np.testing.assert_allclose(estimate_normals(origin, hits, samples, radius),
                               estimate_normals_ref(origin, hits, samples, radius), atol=1e-12)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("bw_angle, bw_dist", [(0.5, 0.5), (0.0, 0.0), (0.2, 0.05)])
def test_tsdf_insert_equals_reference(seed, bw_angle, bw_dist):
    rng = np.random.default_rng(seed)
    res, trunc = 0.05, 0.15
    meta = np.array([-4.0, -4.0, res, 160, 160])
    grids = [(np.full((160, 160), trunc), np.zeros((160, 160)), np.zeros((160, 160), np.int64), np.zeros((160, 160)))
             for _ in range(2)]
    for scan in range(1, 4):      # several scans: weights accumulate and saturate, stamps change
        origin = np.array([0.3, -0.2]) + rng.normal(0, 0.05, 2)
        hits = _scan_cloud(rng)
        hits = hits[np.argsort(np.arctan2(*(hits - origin).T[::-1]))]
        normals = estimate_normals(origin, hits, 10, 0.5)
        counts = [f(*g, scan, meta, origin, hits, normals, trunc, 1.5, bw_angle, bw_dist)
                  for f, g in zip((tsdf_insert, tsdf_insert_ref), grids)]
        assert counts[0] == counts[1] > 0
    for a, b in zip(*grids):
        np.testing.assert_allclose(a, b, atol=1e-12)
    assert grids[0][1].max() == pytest.approx(1.5)      # weights saturate at max_weight


def test_normals_of_a_wall_face_the_sensor():
    origin = np.array([0.2, 0.1])
    hits = _wall_scan(origin, 1.6)
    ang = estimate_normals(origin, hits, 10, 0.5)
    np.testing.assert_allclose(ang, -np.pi / 2, atol=1e-9)    # the wall above faces down


@pytest.mark.parametrize("y_wall", [1.013, 1.05, 1.0761])
def test_tsdf_puts_a_wall_between_cell_centres(y_wall):
    # A wall at a sub-cell offset, seen with range noise from several places: the zero crossing
    # of the interpolated field along x lies on the wall to a few mm. A probability grid can
    # only put it at the centre of a hit cell (here up to 2.5 cm off).
    rng = np.random.default_rng(7)
    grid = TsdfGrid(0.05, (0.0, 0.0), truncation=0.1)
    opts = TsdfInserterConfig()
    for x in np.linspace(-1.0, 1.0, 30):
        origin = np.array([x, 0.0])
        grid.insert(origin, _wall_scan(origin, y_wall, noise=0.01, rng=rng), opts)
    ox, oy = grid.origin
    col = int((0.0 - ox) / 0.05)
    ys = oy + (np.arange(grid.shape[0]) + 0.5) * 0.05
    tsd = grid.tsd[:, col]
    known = grid.weight[:, col] > 0
    k = np.nonzero(known[:-1] & known[1:] & (tsd[:-1] > 0) & (tsd[1:] <= 0))[0]
    assert len(k) == 1
    k = k[0]
    y0 = ys[k] + tsd[k] / (tsd[k] - tsd[k + 1]) * 0.05
    assert abs(y0 - y_wall) < 0.004
    assert np.all(tsd[known & (ys < y_wall - 0.05)] > 0) and np.all(tsd[known & (ys > y_wall + 0.05)] < 0)


def test_tsdf_submap_interface():
    cfg = SubmapsConfig(grid_type="tsdf")
    subs = ActiveSubmaps(cfg)
    subs.insert(np.zeros(2), _wall_scan(np.zeros(2), 1.0), np.zeros((0, 2)))
    s = subs.matching_submap()
    assert isinstance(s, TsdfSubmap) and s.num_range_data == 1
    search, meta = s.search_grid()
    match, meta2 = s.probabilities()
    np.testing.assert_array_equal(meta, meta2)
    assert search.min() >= 0.0 and search.max() <= 1.0
    unknown = s.grid.weight == 0
    assert np.all(search[unknown] == 0.0) and np.all(match[unknown] == 0.0)
    pts = np.array([[0.0, 1.0], [0.0, 0.5], [3.0, 3.0]])
    np.testing.assert_array_equal(s.known_at(pts), [True, False, False])
    p = s.probability_at(np.array([[0.0, 0.93], [0.0, 1.07], [0.0, 0.5]]))
    assert p[0] < 0.5 < p[1] and np.isnan(p[2])
    grid_subs = ActiveSubmaps(SubmapsConfig(grid_type="probability_grid"))
    grid_subs.insert(np.zeros(2), _wall_scan(np.zeros(2), 1.0), np.zeros((0, 2)))
    assert type(grid_subs.matching_submap()) is Submap
    with pytest.raises(ValueError, match="grid_type"):
        SubmapsConfig(grid_type="voxels")
    with pytest.raises(ValueError, match="truncation_distance"):
        TsdfInserterConfig(truncation_distance=0.0)


@pytest.mark.parametrize("grid_type, tolerance, degrees", [("tsdf", 0.004, 0.3), ("probability_grid", 0.025, 1.0)])
def test_scan_matches_back_onto_its_submap(grid_type, tolerance, degrees):
    # a corner room seen from one place; the same scan, started 4 cm and 2 degrees off, is
    # matched back by the least squares of the local SLAM: on the TSDF to a few mm, on the
    # probability grid only to within half a cell (its walls sit at hit-cell centres)
    rng = np.random.default_rng(1)
    origin = np.zeros(2)
    hits = np.vstack([_wall_scan(origin, 1.2), _wall_scan(origin, -0.9)[::2],
                      np.column_stack([np.full(40, 1.5), np.linspace(-0.8, 1.1, 40)])])
    cfg = SubmapsConfig(grid_type=grid_type, free_space_margin_sigmas=0.0)
    sub = TsdfSubmap(0, origin, cfg) if grid_type == "tsdf" else Submap(0, origin, cfg)
    for _ in range(3):
        sub.insert(origin, hits + rng.normal(0, 0.003, hits.shape), np.zeros((0, 2)))
    prob, meta = sub.probabilities()
    truth = np.array([0.0, 0.0, 0.0])
    start = np.array([0.04, -0.03, np.radians(2.0)])
    w = sub.known_at(transform_points(start, hits)).astype(float)
    got = ceres_match(prob, meta, hits, start, start,
                      CeresScanMatcherConfig(translation_weight=0.01, rotation_weight=0.01), w)
    assert np.hypot(*(got - truth)[:2]) < tolerance and abs(got[2]) < np.radians(degrees)


@pytest.mark.kernel
def test_cells_under_matches_reference_and_the_grid(rng):
    grid = TsdfGrid(0.05, (0.3, -0.2), truncation=0.1)
    xy = rng.uniform(-6, 6, (500, 2))
    got = cells_under(grid.meta, xy)
    for a, b, c in zip(got, cells_under_ref(grid.meta, xy), grid.cells(xy)):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, c)
    assert got[2].any() and not got[2].all()
