"""The output map's surface kernels against their numpy references, and the map they build on
simple scenes: a straight wall at random sub-cell offsets and angles, a thin wall seen from
both sides, a corner, a pillar. Scenes are scored with the surface form at 5 mm."""
import numpy as np
import pytest

from metrics.surface import classify_surface
from slam._kernels import surface_map as K
from slam.base import Scan
from slam.output_map import OutputMap, OutputMapConfig
from slam.range_noise import DEFAULT_RANGE_NOISE, RangeNoise, range_noise_from_meta

from tests.slam.synthlog import cast

TAU = 0.005


# --- kernels against references -----------------------------------------------------------

def _hits_case(seed, n_scans=4, per_scan=40, rows=30, cols=34):
    """Hits along a few random lines in cell units, with scan starts, origins and weights."""
    rng = np.random.default_rng(seed)
    px, py, ox, oy, starts = [], [], [], [], [0]
    for _ in range(n_scans):
        o = rng.uniform([5, 5], [cols - 5, rows - 5])
        a = rng.uniform(0, np.pi)
        t = np.sort(rng.uniform(-8, 8, per_scan))
        base = o + rng.uniform(3, 6) * np.array([np.cos(a + np.pi / 2), np.sin(a + np.pi / 2)])
        pts = base + t[:, None] * [np.cos(a), np.sin(a)] + rng.normal(0, 0.3, (per_scan, 2))
        pts[rng.random(per_scan) < 0.1] += rng.normal(0, 4, 2)   # outliers, some off the grid
        px += list(pts[:, 0])
        py += list(pts[:, 1])
        ox += [o[0]] * per_scan
        oy += [o[1]] * per_scan
        starts.append(starts[-1] + per_scan)
    w = rng.uniform(0.5, 2.0, len(px))
    return (np.array(px), np.array(py), w, np.array(ox), np.array(oy), np.array(starts), rows,
            cols, rng)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_hit_sigmas_match_reference(seed):
    rng = np.random.default_rng(seed)
    ranges = rng.uniform(0.1, 3.5, 300)
    ranges[100:140] = 1.0 + rng.normal(0, 0.01, 40)
    starts = np.array([0, 90, 90, 200, 300])
    model = (RangeNoise(stddev=0.002) if seed % 2 else
             RangeNoise(stddev=0.002, bands=((0.5, 0.01, 0.0), (2.0, 0.0, 0.02), (9.0, 0.03, 0.01))))
    noise = model.as_array()
    np.testing.assert_allclose(K.hit_sigmas_ref(ranges, starts, 0, 0.1, noise), model.sigma(ranges),
                               rtol=1e-12)
    np.testing.assert_allclose(K.hit_sigmas(ranges, starts, 2, 0.1, noise),
                               K.hit_sigmas_ref(ranges, starts, 2, 0.1, noise), rtol=1e-12)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_hit_normals_match_reference(seed):
    px, py, w, ox, oy, starts, *_ = _hits_case(seed)
    np.testing.assert_array_equal(K.hit_normals(px, py, w, starts, 3, 5.0, ox, oy),
                                  K.hit_normals_ref(px, py, w, starts, 3, 5.0, ox, oy))


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("radius, spread", [(1, 0), (2, 1), (1, 2)])
def test_project_hits_match_reference(seed, radius, spread):
    px, py, w, ox, oy, starts, rows, cols, rng = _hits_case(seed)
    sector = K.hit_normals(px, py, w, starts, 3, 5.0, ox, oy)
    dx, dy = px + rng.normal(0, 0.1, len(px)), py + rng.normal(0, 0.1, len(py))
    out = K.project_hits(px, py, dx, dy, w, sector, spread, rows, cols, radius, 4)
    ref = K.project_hits_ref(px, py, dx, dy, w, sector, spread, rows, cols, radius, 4)
    np.testing.assert_allclose(out, ref, atol=1e-7)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_carve_free_matches_reference(seed):
    px, py, w, ox, oy, starts, rows, cols, rng = _hits_case(seed)
    origins = np.stack([ox[starts[:-1]], oy[starts[:-1]]], axis=1)
    margin = rng.uniform(0, 2, len(px))
    free, seen = K.carve_free(origins, starts, px, py, margin, rows, cols)
    free_ref, seen_ref = K.carve_free_ref(origins, starts, px, py, margin, rows, cols)
    np.testing.assert_array_equal(free, free_ref)
    np.testing.assert_array_equal(seen, seen_ref)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_mark_surface_matches_reference(seed):
    px, py, w, _, _, _, rows, cols, _ = _hits_case(seed)
    out, total = K.mark_surface(px, py, w, rows, cols, 2, 0.3)
    ref, total_ref = K.mark_surface_ref(px, py, w, rows, cols, 2, 0.3)
    np.testing.assert_array_equal(out, ref)
    np.testing.assert_allclose(total, total_ref)


# --- the range noise model ----------------------------------------------------------------

def test_range_noise_from_meta_reads_the_log_and_defaults_otherwise():
    meta = {"noise": {"lidar": {"stddev": 0.01, "near_accuracy": 0.0, "far_accuracy_ratio": 0.0,
                                "split": 0.5, "accuracy_sigmas": 2.0, "drop_prob": 0.01}}}
    assert range_noise_from_meta(meta).sigma(3.0) == pytest.approx(0.01)
    assert range_noise_from_meta({}) == DEFAULT_RANGE_NOISE
    assert range_noise_from_meta({"noise": {"lidar": {"stddev": -1}}}) == DEFAULT_RANGE_NOISE
    # the LDS-01 datasheet: +-15 mm below 0.5 m, +-5 % beyond, as 2 sigma
    assert DEFAULT_RANGE_NOISE.sigma(0.3) == pytest.approx(0.0075)
    assert DEFAULT_RANGE_NOISE.sigma(2.0) == pytest.approx(0.05)


# --- scenes -------------------------------------------------------------------------------

def _map_of(segments, viewpoints, seed, noise=DEFAULT_RANGE_NOISE, beams=360):
    """The output map of one noisy scan from each viewpoint (K, 2) among `segments`."""
    rng = np.random.default_rng(seed)
    angles = np.linspace(0, 2 * np.pi, beams, endpoint=False)
    dirs = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    out = OutputMap(OutputMapConfig(), center=viewpoints[0])
    for i, v in enumerate(viewpoints):
        r = cast(segments, np.asarray(v, float), dirs, 3.5)
        noisy = r + noise.sigma(np.where(np.isfinite(r), r, 0.0)) * rng.standard_normal(beams)
        noisy[~(noisy > 0.12)] = np.inf
        scan = Scan(float(i) * 0.2, noisy, angles, 0.12, 3.5, np.zeros(3), 0.0, i, noise)
        out.insert(scan, np.array([v[0], v[1], 0.0]))
    return out.to_grid()


def _score(grid, segments):
    c = classify_surface(grid, segments, (0.0, 0.0, 0.0), TAU)
    return c.portion.surface_precision, c.portion.surface_sensitivity, len(c.tp)


def _rot(points, yaw, centre):
    c, s = np.cos(yaw), np.sin(yaw)
    p = np.asarray(points, float) - centre
    return np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]], axis=1) + centre


@pytest.mark.parametrize("seed", range(6))
def test_straight_wall_at_any_offset_and_angle_is_one_cell_thick_on_its_surface(seed):
    rng = np.random.default_rng(seed)
    yaw = rng.uniform(-np.pi, np.pi)
    centre = rng.uniform(0, 0.05, 2) + [1.0, 1.0]     # random sub-cell offset
    ends = _rot([[-1.0, 0.0], [1.0, 0.0]], yaw, centre)
    wall = np.hstack([ends[0], ends[1]])[None, :]
    views = _rot(np.stack([rng.uniform(-0.8, 0.8, 25), -rng.uniform(0.4, 1.6, 25)], axis=1), yaw,
                 centre)
    grid = _map_of(wall, views, seed)
    # the stretch every viewpoint can see well: the wall's middle 1.4 m
    mid = _rot([[-0.7, 0.0], [0.7, 0.0]], yaw, centre)
    p, _, n = _score(grid, wall)
    _, s, _ = _score(grid, np.hstack([mid[0], mid[1]])[None, :])
    assert p >= 0.95 and s >= 0.95, (p, s)
    # one cell thick: about as many cells as a 4-connected line of 2 m crosses
    assert n <= 1.25 * 2.0 / 0.05 * (abs(np.cos(yaw)) + abs(np.sin(yaw))), n


@pytest.mark.parametrize("seed", range(3))
def test_thin_wall_seen_from_both_sides_keeps_both_faces(seed):
    rng = np.random.default_rng(seed)
    y0 = 1.0 + rng.uniform(0, 0.05)
    faces = np.array([[0.0, y0, 2.0, y0], [2.0, y0 + 0.05, 0.0, y0 + 0.05]])
    slab = np.vstack([faces, [[0.0, y0, 0.0, y0 + 0.05], [2.0, y0, 2.0, y0 + 0.05]]])
    x = rng.uniform(0.3, 1.7, 30)
    views = np.stack([x, np.where(np.arange(30) % 2, y0 + 0.05 + rng.uniform(0.4, 1.2, 30),
                                  y0 - rng.uniform(0.4, 1.2, 30))], axis=1)
    grid = _map_of(slab, views, seed)
    p, _, _ = _score(grid, slab)
    assert p >= 0.95, p
    for face in faces:
        inner = face.copy()
        inner[[0, 2]] = np.clip(inner[[0, 2]], 0.4, 1.6)
        _, s, _ = _score(grid, inner[None, :])
        assert s >= 0.95, (face, s)


@pytest.mark.parametrize("seed", range(3))
def test_corner_is_drawn_to_its_vertex(seed):
    rng = np.random.default_rng(seed)
    yaw = rng.uniform(-np.pi, np.pi)
    corner = 1.0 + rng.uniform(0, 0.05, 2)
    pts = _rot([[0.0, 1.2], [0.0, 0.0], [1.2, 0.0]], yaw, corner)
    walls = np.array([np.hstack([pts[0], pts[1]]), np.hstack([pts[1], pts[2]])])
    views = _rot(rng.uniform(0.3, 1.0, (20, 2)), yaw, corner)
    grid = _map_of(walls, views, seed)
    p, s, _ = _score(grid, walls)
    assert p >= 0.95 and s >= 0.95, (p, s)
    # the vertex's cell (or one touching the vertex within tau) is occupied
    occ = np.argwhere(grid.occupied())
    centres = grid.cell_to_world(occ[:, 0], occ[:, 1])
    gap = np.max(np.abs(centres - pts[1]), axis=1)   # Chebyshev distance to the cell's square
    assert np.min(gap) <= grid.resolution / 2 + TAU


@pytest.mark.parametrize("seed", range(2))
def test_pillar_seen_from_around(seed):
    rng = np.random.default_rng(seed)
    centre = np.array([1.0, 1.0]) + rng.uniform(0, 0.05, 2)
    k = 48
    a = np.linspace(0, 2 * np.pi, k + 1)
    ring = centre + 0.15 * np.stack([np.cos(a), np.sin(a)], axis=1)
    pillar = np.hstack([ring[:-1], ring[1:]])
    b = rng.uniform(0, 2 * np.pi, 30)
    views = centre + rng.uniform(0.5, 1.0, 30)[:, None] * np.stack([np.cos(b), np.sin(b)], axis=1)
    grid = _map_of(pillar, views, seed)
    p, s, _ = _score(grid, pillar)
    assert p >= 0.9 and s >= 0.9, (p, s)


def test_walls_seen_only_from_afar_are_mapped():
    """A wall seen only from 2.9-3.3 m (sigma 7-8 cm) is still mapped (every hit up to the
    sensor's range); its precision at 5 mm is bounded by what 40 such scans can tell."""
    wall = np.array([[0.0, 1.025, 3.0, 1.025]])
    views = np.stack([np.linspace(0.8, 2.2, 40), np.full(40, 1.025 - 2.9)], axis=1)
    grid = _map_of(wall, views, 0)
    mid = np.array([[0.9, 1.025, 2.1, 1.025]])
    _, s, _ = _score(grid, mid)
    p, _, _ = _score(grid, wall)
    assert s >= 0.9 and p >= 0.85, (p, s)


def test_noise_model_is_taken_from_the_scans_unless_configured():
    wall = np.array([[0.0, 1.0, 2.0, 1.0]])
    views = np.stack([np.linspace(0.5, 1.5, 5), np.full(5, 0.3)], axis=1)
    sharp = RangeNoise(near_accuracy=0.002, far_accuracy_ratio=0.002)
    out = OutputMap(OutputMapConfig())
    assert out._noise is None
    grid = _map_of(wall, views, 0, noise=sharp)
    assert grid.occupied().any()
    configured = OutputMap(OutputMapConfig(range_noise=sharp))
    assert configured._noise == sharp
