"""slam.pf._map_kernel / pf_match against their plain references, and the tile sharing."""
import numpy as np
import pytest

from slam.pf._map_kernel import (insert_scan_ref, narrow_box, patch_box, ray_cells,
                                  ray_cells_ref, read_patch)
from slam.pf._match_kernel import (beam_cache, grid_likelihoods, hill_climb, hill_climb_ref,
                                    make_params, proposal_moments, proposal_moments_ref,
                                    score_above, score_and_likelihood, score_and_likelihood_ref)
from slam.pf._proposal_kernel import propose_particles, propose_particles_ref
from slam.pf.maps import TiledMaps

PARAMS = make_params(sigma=0.05, lsigma=0.075, null_likelihood=-0.5, fullness=0.3, kernel=1,
                     lstep=0.05, astep=0.05, iterations=5, llsamplerange=0.01,
                     llsamplestep=0.01, lasamplerange=0.005, lasamplestep=0.005)
ORIGIN = np.array([-0.032, 0.0])


def _room_scan(rng, pose, beams=120, size=2.4):
    """Beam ends (robot frame) of a square room [-size/2, size/2]^2 seen from pose, with noise."""
    a = np.linspace(-np.pi, np.pi, beams, endpoint=False) + rng.uniform(0, 0.05)
    c, s = np.cos(pose[2] + a), np.sin(pose[2] + a)
    half = size / 2
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (half - pose[0]) / c, (-half - pose[0]) / c)
        ty = np.where(s > 0, (half - pose[1]) / s, (-half - pose[1]) / s)
    r = np.minimum(np.abs(tx), np.abs(ty)) + rng.normal(0, 0.005, beams)
    ends = np.stack([r * np.cos(a), r * np.sin(a)], axis=1) + ORIGIN
    hit = rng.random(beams) > 0.1
    return ends, hit


def _patch(maps, p, box):
    """Particle p's patch over box (first row, column, rows, columns): (prob, mean_off,
    corner) as the proposal reads it."""
    box = np.asarray(box, dtype=np.int64)
    prob, hits = np.empty(box[2:], np.float32), np.empty(box[2:], np.float32)
    mean_off = np.empty((*box[2:], 2), np.float32)
    read_patch(maps.tables[p], maps.pool, maps.grid_meta, box, box, prob, hits, mean_off)
    return prob, mean_off, box[:2].copy()


def _frees(ends, delta=0.05):
    d = ends - ORIGIN
    return ends - delta * d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(5))
def test_ray_cells_matches_clipping(seed):
    rng = np.random.default_rng(seed)
    bc = np.empty(400, np.int64)
    br = np.empty(400, np.int64)
    for _ in range(60):
        u0, v0, u1, v1 = rng.uniform(-20, 60, 4)
        n = ray_cells(u0, v0, u1, v1, bc, br)
        got = set(zip(bc[:n].tolist(), br[:n].tolist()))
        ref = ray_cells_ref(u0, v0, u1, v1)
        # a segment grazing a cell corner within rounding may take either neighbour
        assert len(got ^ ref) <= 2
        assert (bc[0], br[0]) == (int(np.floor(u0)), int(np.floor(v0)))
        assert (bc[n - 1], br[n - 1]) == (int(np.floor(u1)), int(np.floor(v1)))
        assert np.all(np.abs(np.diff(bc[:n])) + np.abs(np.diff(br[:n])) == 1)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(3))
def test_insert_with_sharing_matches_dense_reference(seed):
    rng = np.random.default_rng(seed)
    maps = TiledMaps(3, np.zeros(2), 2.0, 0.05, tile=8, capacity=4)
    dense = [np.zeros((maps.tables.shape[1] * 8,) * 2 + (4,)) for _ in range(3)]
    for step in range(3):
        poses = np.c_[rng.uniform(-0.3, 0.3, (3, 2)), rng.uniform(-np.pi, np.pi, 3)]
        ends, hit = _room_scan(rng, poses[0])
        maps.insert(poses, ORIGIN, ends, hit)
        for i in range(3):
            insert_scan_ref(dense[i], maps.grid_meta, poses[i], ORIGIN, ends, hit)
        for i in range(3):
            got = maps.dense(i)
            np.testing.assert_allclose(got[..., [0, 2, 3]], dense[i][..., [0, 2, 3]], atol=1e-4)
            # visits: the walk may differ from the clipping reference at exact corner grazes
            assert np.sum(got[..., 1] != dense[i][..., 1]) <= 3
        anc = rng.integers(0, 3, 3)
        maps.resample(anc)
        dense = [dense[a].copy() for a in anc]


def test_resampled_particles_share_tiles_until_written():
    maps = TiledMaps(30, np.zeros(2), 25.0, 0.05, tile=16)
    rng = np.random.default_rng(0)
    ends, hit = _room_scan(rng, np.zeros(3))
    maps.insert(np.zeros((30, 3)), ORIGIN, ends, hit)
    one = maps.tiles_in_use() // 30
    maps.resample(np.zeros(30, dtype=np.int64))
    assert maps.tiles_in_use() == one  # 30 particles, one copy of the map
    maps.insert(np.zeros((30, 3)) + [[0.01, 0, 0]] * 30, ORIGIN, ends, hit)
    assert maps.tiles_in_use() == 30 * one  # each wrote into all of them: each has its own
    # a 50 m x 50 m table for 30 particles costs little until tiles are written
    assert maps.tables.nbytes < 5e6


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(3))
def test_score_likelihood_hill_climb_and_proposal_match_references(seed):
    rng = np.random.default_rng(seed)
    maps = TiledMaps(2, np.zeros(2), 2.0, 0.05, tile=8)
    dense = np.zeros((maps.tables.shape[1] * 8,) * 2 + (4,))
    for _ in range(4):
        pose = np.r_[rng.uniform(-0.2, 0.2, 2), rng.uniform(-0.1, 0.1)]
        ends, hit = _room_scan(rng, pose)
        maps.insert(np.tile(pose, (2, 1)), ORIGIN, ends, hit)
        insert_scan_ref(dense, maps.grid_meta, pose, ORIGIN, ends, hit)
    truth = np.array([0.05, -0.03, 0.02])
    ends, hit = _room_scan(rng, truth)
    hits = np.ascontiguousarray(ends[hit])
    frees = _frees(hits)
    start = truth + np.r_[rng.uniform(-0.04, 0.04, 2), rng.uniform(-0.03, 0.03)]
    poses = np.stack([start, truth])
    cells = np.floor((poses[:, 1::-1] - maps.grid_meta[1::-1]) / 0.05).astype(np.int64) - 40
    patches = [_patch(maps, p, [*cells[p], 80, 80]) for p in range(2)]
    for p in range(2):
        for q in (poses[p], poses[p] + [0.013, -0.021, 0.01]):
            got = score_and_likelihood(*patches[p], maps.grid_meta, q, hits, frees, PARAMS)
            ref = score_and_likelihood_ref(dense, maps.grid_meta, q, hits, frees, PARAMS)
            np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-6)
    matched, score = hill_climb(*patches[0], maps.grid_meta, start, hits, frees, PARAMS)
    ref_pose, ref_score = hill_climb_ref(dense, maps.grid_meta, start, hits, frees, PARAMS)
    np.testing.assert_allclose(matched, ref_pose, atol=1e-9)
    assert score == pytest.approx(ref_score, rel=1e-5)
    # recovery: from up to 4 cm and 1.7 degrees off, the match lands within a cell and 1.5 degrees
    assert np.hypot(*(matched[:2] - truth[:2])) < 0.05 and abs(matched[2] - truth[2]) < 0.026
    prior_std = np.full(3, 0.03)
    for p, centre in enumerate((matched, truth)):
        m, cov, log_eta = proposal_moments(*patches[p], maps.grid_meta, centre, poses[p],
                                           prior_std, hits, frees, PARAMS)
        rm, rc, rl = proposal_moments_ref(dense, maps.grid_meta, centre, poses[p], prior_std,
                                          hits, frees, PARAMS)
        np.testing.assert_allclose(m, rm, atol=1e-9)
        np.testing.assert_allclose(cov, rc, atol=1e-10)
        assert log_eta == pytest.approx(rl, rel=1e-6)
        assert np.all(np.linalg.eigvalsh(cov) >= -1e-15)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(3))
def test_propose_particles_is_the_loop_over_the_single_particle_kernels(seed):
    """The compiled proposal reuses one set of patch buffers for all particles and reads only
    the cells within `room` of the scan's end points; it must give what separate arrays per
    particle, every cell read, give, with boxes of different sizes (clipped to each particle's
    tiles) and particles whose match is ignored (below minimum_score)."""
    rng = np.random.default_rng(seed)
    maps = TiledMaps(3, np.zeros(2), 2.0, 0.05, tile=8)
    for step in range(4):
        pose = np.r_[rng.uniform(-0.2, 0.2, 2), rng.uniform(-0.1, 0.1)]
        ends, hit = _room_scan(rng, pose)
        poses = pose + np.c_[rng.normal(0, 0.01, (3, 2)), rng.normal(0, 0.01, 3)]
        maps.insert(poses, ORIGIN, ends, hit)
        if step == 1:
            maps.resample(np.array([0, 0, 2]))
    ends, hit = _room_scan(rng, np.zeros(3))
    hits = np.ascontiguousarray(ends[hit])
    frees = _frees(hits)
    poses = np.c_[rng.uniform(-0.03, 0.03, (3, 2)), rng.uniform(-0.02, 0.02, 3)]
    poses[2] += [0.4, 0.3, 0.0]        # its box reaches past the tiles written
    args = (maps.tables, maps.pool, maps.grid_meta, poses, poses + 0.001, np.full(3, 0.02),
            hits, frees, PARAMS, 30, 10, 5, 0.2, np.full(3, 100.0))
    for minimum_score in (0.0, 1e9):
        got = propose_particles(*args, minimum_score)
        want = propose_particles_ref(*args, minimum_score)
        np.testing.assert_array_equal(got[0], want[0])
        # the covariance is inverted by numba's LAPACK call and by numpy's: rounding apart
        np.testing.assert_allclose(got[1], want[1], rtol=1e-12, atol=1e-18)
        np.testing.assert_array_equal(got[2], want[2])


def test_patch_box_is_clipped_to_the_tiles_written():
    maps = TiledMaps(1, np.zeros(2), 2.0, 0.05, tile=8)
    rng = np.random.default_rng(0)
    ends, hit = _room_scan(rng, np.zeros(3), size=1.0)
    maps.insert(np.zeros((1, 3)), ORIGIN, ends, hit)
    a, b = np.nonzero(maps.tables[0] >= 0)
    box = np.empty(4, np.int64)
    patch_box(maps.tables[0], maps.grid_meta, np.zeros(3), 100, box)
    assert list(box) == [a.min() * 8, b.min() * 8, (a.max() - a.min() + 1) * 8,
                         (b.max() - b.min() + 1) * 8]
    patch_box(maps.tables[0], maps.grid_meta, np.zeros(3), 3, box)
    centre = int(np.floor(-maps.grid_meta[0] / 0.05))
    assert list(box) == [centre - 3, centre - 3, 6, 6]


@pytest.mark.parametrize("seed", range(3))
def test_narrow_box_is_the_points_bounding_box_grown_by_the_room(seed):
    """narrow_box against numpy: the cells within `room` of the placed points' bounding box,
    inside the box it was given."""
    rng = np.random.default_rng(seed)
    grid_meta = np.array([-10.0, -10.0, 0.05, 400, 400, 3])
    pose = np.r_[rng.uniform(-1, 1, 2), rng.uniform(-np.pi, np.pi)]
    pts = rng.uniform(-2.0, 2.0, (50, 2)) * [1.0, 0.3]
    c, s = np.cos(pose[2]), np.sin(pose[2])
    world = pose[:2] + pts @ np.array([[c, s], [-s, c]])
    cells = np.floor((world - grid_meta[:2]) / 0.05).astype(int)     # (column, row)
    for start, room in (([0, 0, 400, 400], 10), ([180, 170, 40, 60], 4)):
        box = np.array(start, np.int64)
        narrow_box(grid_meta, pose, pts, room, box)
        r0 = max(start[0], cells[:, 1].min() - room)
        c0 = max(start[1], cells[:, 0].min() - room)
        r1 = min(start[0] + start[2], cells[:, 1].max() + room + 1)
        c1 = min(start[1] + start[3], cells[:, 0].max() + room + 1)
        assert list(box) == [r0, c0, max(r1 - r0, 0), max(c1 - c0, 0)]


def _room_patch(rng):
    """One particle's map of the square room after four scans, its 4 m patch around the
    origin and a fresh scan from there: (grid_meta, prob, mean_off, corner, hits, frees)."""
    maps = TiledMaps(1, np.zeros(2), 2.0, 0.05, tile=8)
    for _ in range(4):
        pose = np.r_[rng.uniform(-0.2, 0.2, 2), rng.uniform(-0.1, 0.1)]
        ends, hit = _room_scan(rng, pose)
        maps.insert(pose[None, :], ORIGIN, ends, hit)
    ends, hit = _room_scan(rng, np.zeros(3))
    hits = np.ascontiguousarray(ends[hit])
    r0, c0 = np.floor(-maps.grid_meta[1::-1] / 0.05).astype(np.int64) - 40
    prob, mean_off, corner = _patch(maps, 0, [r0, c0, 80, 80])
    return maps.grid_meta, prob, mean_off, corner, hits, _frees(hits)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(3))
def test_score_above_is_the_score_or_stays_at_or_below_the_bound(seed):
    rng = np.random.default_rng(seed)
    meta, prob, mean_off, corner, hits, frees = _room_patch(rng)
    cache = beam_cache(len(hits), int(PARAMS[4]))     # shared by all poses, as in the climb
    stopped_early = 0
    for _ in range(20):
        q = np.r_[rng.uniform(-0.08, 0.08, 2), rng.uniform(-0.06, 0.06)]
        full, _ = score_and_likelihood(prob, mean_off, corner, meta, q, hits, frees, PARAMS)
        for bound in (-1.0, full - 1.0, full - 1e-9, full, full + 1e-9, full + 1.0,
                      0.9 * len(hits)):
            got = score_above(prob, mean_off, corner, meta, q, hits, frees, PARAMS, bound, *cache)
            if full > bound:
                assert got == pytest.approx(full, rel=1e-12)
            else:
                assert got <= bound
                stopped_early += got < full - 1e-9
    # the point of it: a bound far above the score ends the sum before the last beam
    assert stopped_early > 0


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(3))
def test_grid_likelihoods_equal_one_evaluation_per_pose(seed):
    # a grid of 3 cm steps crosses cell borders often: the candidates kept from one pose to
    # the next must be gathered again whenever the hit or the free cell changes
    rng = np.random.default_rng(seed)
    meta, prob, mean_off, corner, hits, frees = _room_patch(rng)
    nl, ls, na, ast = 2, 0.03, 1, 0.02
    centre = np.r_[rng.uniform(-0.05, 0.05, 2), rng.uniform(-0.05, 0.05)]
    got = np.empty((2 * nl + 1) ** 2 * (2 * na + 1))
    grid_likelihoods(prob, mean_off, corner, meta, centre, nl, ls, na, ast, hits, frees, PARAMS, got)
    want = [score_and_likelihood(prob, mean_off, corner, meta, centre + [ix * ls, iy * ls, ia * ast],
                                 hits, frees, PARAMS)[1]
            for ix in range(-nl, nl + 1) for iy in range(-nl, nl + 1) for ia in range(-na, na + 1)]
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)
    assert np.ptp(got) > 1.0        # the poses differ enough for the likelihoods to differ


@pytest.mark.parametrize("center", [(0.475, 0.5), (0.785, 0.485), (-1.2345, 3.01), (0.0, 0.0)])
def test_maps_lie_on_the_world_lattice(center):
    """Cell boundaries at multiples of the resolution, wherever the robot starts: the true map's
    lattice, so a wall's face falls in the same cell in both (a start 0.475 m from the origin
    once put every x face of the swirl worlds half a cell off)."""
    maps = TiledMaps(1, np.array(center), 2.0, 0.05, tile=8)
    ox, oy, res = maps.grid_meta[:3]
    assert ox / res == pytest.approx(round(ox / res), abs=1e-9)
    assert oy / res == pytest.approx(round(oy / res), abs=1e-9)
    half = maps.grid_meta[3] * res / 2
    assert abs(ox + half - center[0]) <= res / 2 + 1e-12      # still centred on the start
    assert abs(oy + half - center[1]) <= res / 2 + 1e-12
