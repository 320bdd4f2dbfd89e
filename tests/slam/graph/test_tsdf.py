"""TSDF submaps of `graph`: the kernels against their references, the surface they recover, the
submap interface the matchers read, and scan matching on them."""
import numpy as np
import pytest

from slam.graph._match_kernel import directional_value_ref, match_lm_directional, match_lm_directional_ref
from slam.graph._tsdf_kernel import (cells_under, cells_under_ref, direction_mix, direction_mix_ref, direction_mixes,
                                    estimate_normals, estimate_normals_ref, tsdf_insert, tsdf_insert_ref)
from slam.graph.config import CeresScanMatcherConfig, SubmapsConfig, TsdfInserterConfig
from slam.graph.scan_matching import ceres_match, submap_match
from slam.graph.submaps import ActiveSubmaps, Submap
from slam.graph.tsdf import TsdfGrid, TsdfSubmap, scan_normals
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


def _grids(n, trunc, directions):
    """Empty TSDF layers as tsdf_insert takes them: tsd, weight, stamp, match, then the
    directional tsd, weight, stamp of `directions` layers."""
    return (np.full((n, n), trunc), np.zeros((n, n)), np.zeros((n, n), np.int32), np.zeros((n, n)),
            np.full((directions, n, n), trunc), np.zeros((directions, n, n)),
            np.zeros((directions, n, n), np.int32))


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("bw_angle, bw_dist, directions", [(0.5, 0.5, 4), (0.0, 0.0, 0), (0.2, 0.05, 6)])
def test_tsdf_insert_equals_reference(seed, bw_angle, bw_dist, directions):
    rng = np.random.default_rng(seed)
    res, trunc = 0.05, 0.15
    meta = np.array([-4.0, -4.0, res, 160, 160])
    grids = [_grids(160, trunc, directions) for _ in range(2)]
    for scan in range(1, 4):      # several scans: weights accumulate and saturate, stamps change
        origin = np.array([0.3, -0.2]) + rng.normal(0, 0.05, 2)
        hits = _scan_cloud(rng)
        hits = hits[np.argsort(np.arctan2(*(hits - origin).T[::-1]))]
        normals = estimate_normals(origin, hits, 10, 0.5)
        counts = [f(*g[:4], scan, meta, origin, hits, normals, trunc, 1.5, bw_angle, bw_dist, *g[4:])
                  for f, g in zip((tsdf_insert, tsdf_insert_ref), grids)]
        assert counts[0] == counts[1] > 0
    for a, b in zip(*grids):
        np.testing.assert_allclose(a, b, atol=1e-12)
    assert grids[0][1].max() == pytest.approx(1.5)      # weights saturate at max_weight
    if directions:
        assert (grids[0][5] > 0).sum(axis=0).max() >= 2       # a cell seen from two directions
        np.testing.assert_array_less(grids[0][5].max(axis=(1, 2)), 1.5 + 1e-12)


@pytest.mark.kernel
@pytest.mark.parametrize("directions", [3, 4, 8])
def test_direction_mix_equals_reference(directions):
    angles = np.concatenate([np.linspace(-7.0, 7.0, 301), np.arange(-8, 9) * 2 * np.pi / directions])
    for a in angles:
        got, ref = direction_mix(a, directions), direction_mix_ref(a, directions)
        assert got[0] == ref[0] and got[2] == ref[2]
        np.testing.assert_allclose([got[1], got[3]], [ref[1], ref[3]], atol=1e-9)
        assert got[1] + got[3] == pytest.approx(1.0) and 0 <= got[1] <= 1
    np.testing.assert_allclose(direction_mixes(angles, directions),
                               [direction_mix_ref(a, directions) for a in angles], atol=1e-9)
    k0, a0, _, _ = direction_mix(np.pi / 2, 4)       # a normal on a layer's direction: all its own
    assert k0 == 1 and a0 == pytest.approx(1.0)


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


def _thin_wall_submap(directions):
    """A wall 0.12 m thick (faces y = 1.0 and 1.12) seen from both sides with range noise:
    the TSDF submap and the scan of its lower face from (0, 0)."""
    rng = np.random.default_rng(3)
    cfg = SubmapsConfig(tsdf=TsdfInserterConfig(normal_directions=directions))
    sub = TsdfSubmap(0, np.zeros(2), cfg)
    below, above = np.array([0.0, 0.0]), np.array([0.0, 2.1])
    for _ in range(4):
        for origin, y in ((below, 1.0), (above, 1.12)):
            sub.insert(origin, _wall_scan(origin, y, noise=0.003, rng=rng), np.zeros((0, 2)))
    return sub, _wall_scan(below, 1.0), cfg


@pytest.mark.parametrize("directions", [0, 4])
def test_directional_tsdf_keeps_the_faces_of_a_thin_wall_apart(directions):
    # Each ray updates the band 0.1 m behind its hit, which on a 0.12 m wall reaches the cells
    # of the other face: in the one field the lower face's zero crossing moves, the scan of it
    # is matched away from where it was taken; the directional layers keep the faces apart.
    sub, hits, cfg = _thin_wall_submap(directions)
    normals = scan_normals(np.zeros(2), hits, cfg.tsdf) if directions else None
    got = submap_match(sub, hits, normals, np.zeros(3), np.zeros(3),
                       CeresScanMatcherConfig(translation_weight=0.01, rotation_weight=0.01))
    if directions:
        assert abs(got[1]) < 0.002 and abs(got[2]) < np.radians(0.1)
    else:
        assert abs(got[1]) > 0.004          # the failure the layers remove


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(3))
def test_match_lm_directional_matches_reference(seed):
    rng = np.random.default_rng(seed)
    sub, hits, cfg = _thin_wall_submap(4)
    side = np.column_stack([np.full(30, 1.4), np.linspace(-0.5, 0.9, 30)])
    sub.insert(np.zeros(2), side, np.zeros((0, 2)))
    pts = np.vstack([hits, side])
    normals = scan_normals(np.zeros(2), pts, cfg.tsdf)
    dir_tsd, dir_weight, trunc, meta = sub.directional()
    start = rng.normal(0, [0.02, 0.02, 0.01])
    mix = direction_mixes(normals + start[2], 4)
    w = rng.uniform(0.2, 1.0, len(pts))
    # the cost at the start (no iteration) from the kernel's interpolation and the reference's
    m = directional_value_ref(dir_tsd, dir_weight, trunc, meta, transform_points(start, pts), mix)
    _, c0 = match_lm_directional(dir_tsd, dir_weight, trunc, mix, meta, pts, w, start, start, 1.0, 0.1, 0.1, 0)
    assert c0 == pytest.approx(float(np.sum(w / w.sum() * (1 - m) ** 2)), rel=1e-9)
    assert 0 < m.min() and m.max() < 2
    a, ca = match_lm_directional(dir_tsd, dir_weight, trunc, mix, meta, pts, w, start, start, 1.0, 0.1, 0.1, 50)
    b, cb = match_lm_directional_ref(dir_tsd, dir_weight, trunc, mix, meta, pts, w, start, start, 1.0, 0.1, 0.1)
    np.testing.assert_allclose(a, b, atol=2e-3)
    assert ca == pytest.approx(cb, rel=1e-2, abs=1e-6)
