"""slam.pf._refine_kernel against its reference; slam.pf.proposal.refine_pose, the
Gauss-Newton refinement, recovering known offsets on a particle's map, and its information."""
import numpy as np
import pytest

from slam.pf._map_kernel import read_patch, read_patch_ref
from slam._kernels.gauss_newton import add_prior, gn_update
from slam.pf._refine_kernel import line_iterate, line_normal_equations, line_normal_equations_ref
from slam.pf.proposal import refine_pose
from slam.pf.maps import TiledMaps
from tests.slam.pf.test_kernels import ORIGIN, PARAMS, _frees


def _refine(maps, box, pts, start, prior, prior_w, iterations=10):
    """refine_pose with the free points one cell before each end point."""
    return refine_pose(maps, 0, box, pts, _frees(pts), start, PARAMS, iterations, 0.2, prior,
                       prior_w)


def _box_scan(rng, pose, beams=360, half=(1.6, 1.1), sigma=0.005):
    """Beam ends (robot frame) of an empty rectangular room [-hx, hx] x [-hy, hy] seen from
    pose (the lidar at ORIGIN in the robot frame), with range noise."""
    hx, hy = half
    a = np.linspace(-np.pi, np.pi, beams, endpoint=False)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    lx, ly = pose[0] + c * ORIGIN[0] - s * ORIGIN[1], pose[1] + s * ORIGIN[0] + c * ORIGIN[1]
    wc, ws = np.cos(pose[2] + a), np.sin(pose[2] + a)
    with np.errstate(divide="ignore"):
        tx = np.where(wc > 0, (hx - lx) / wc, (-hx - lx) / wc)
        ty = np.where(ws > 0, (hy - ly) / ws, (-hy - ly) / ws)
    r = np.minimum(np.abs(tx), np.abs(ty)) + rng.normal(0, sigma, beams)
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1) + ORIGIN


def test_refinement_recovers_offsets_from_a_map_of_noisy_scans():
    """Cartographer-style recovery: a map from scans at known poses, then a new scan matched
    from 25 seeded offsets of up to 4 cm and 2 degrees lands within 1 cm and 0.3 degrees."""
    rng = np.random.default_rng(7)
    maps = TiledMaps(1, np.zeros(2), 5.0, 0.05, tile=16)
    for _ in range(12):
        pose = np.r_[rng.uniform(-0.5, 0.5), rng.uniform(-0.3, 0.3), rng.uniform(-np.pi, np.pi)]
        ends = _box_scan(rng, pose, sigma=0.01)
        maps.insert(pose[None, :], ORIGIN, ends, np.ones(len(ends), bool))
    rows = int(maps.grid_meta[3])
    box = np.array([rows // 2 - 40, rows // 2 - 40, 80, 80], dtype=np.int64)
    no_prior = np.zeros(3)
    errors = []
    for _ in range(25):
        truth = np.r_[rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3), rng.uniform(-np.pi, np.pi)]
        pts = _box_scan(rng, truth, sigma=0.01)
        start = truth + np.r_[rng.uniform(-0.04, 0.04, 2), np.radians(rng.uniform(-2, 2))]
        est, _ = _refine(maps, box, pts, start, no_prior, no_prior)
        errors.append([np.hypot(*(est[:2] - truth[:2])), abs(est[2] - truth[2])])
    errors = np.array(errors)
    assert errors[:, 0].max() < 0.01
    assert np.degrees(errors[:, 1]).max() < 0.3


def test_prior_holds_the_unconstrained_direction():
    """Between two parallel walls nothing fixes the motion along them: without a prior the
    steps may wander along the walls; with the motion prior the estimate keeps its x."""
    rng = np.random.default_rng(3)
    maps = TiledMaps(1, np.zeros(2), 5.0, 0.05, tile=16)

    def corridor_scan(pose, sigma=0.01):
        a = np.linspace(-np.pi, np.pi, 360, endpoint=False)
        ly = pose[1] + np.sin(pose[2]) * ORIGIN[0]
        ws = np.sin(pose[2] + a)
        with np.errstate(divide="ignore"):
            r = np.where(ws > 0, (0.8 - ly) / ws, (-0.8 - ly) / ws)
        ok = np.isfinite(r) & (r < 3.0)
        r, a = r[ok] + rng.normal(0, sigma, ok.sum()), a[ok]
        return np.stack([r * np.cos(a), r * np.sin(a)], axis=1) + ORIGIN

    for x in np.linspace(-0.5, 0.5, 6):
        pose = np.array([x, 0.0, 0.0])
        ends = corridor_scan(pose)
        maps.insert(pose[None, :], ORIGIN, ends, np.ones(len(ends), bool))
    rows = int(maps.grid_meta[3])
    box = np.array([rows // 2 - 40, rows // 2 - 70, 80, 140], dtype=np.int64)
    truth = np.array([0.1, 0.05, 0.0])
    pts = corridor_scan(truth)
    start = truth + [0.0, -0.03, 0.01]
    prior_w = 3.0 / np.array([0.02, 0.02, 0.04]) ** 2
    est, info = _refine(maps, box, pts, start, truth, prior_w)
    assert abs(est[0] - truth[0]) < 0.005       # held by the prior
    assert abs(est[1] - truth[1]) < 0.01        # set by the walls
    assert abs(est[2] - truth[2]) < np.radians(0.3)
    # the proposal's spread: along the corridor mostly the prior (2 cm, weighted 3) holds the
    # pose, across it the walls fix it to millimetres
    std = np.sqrt(np.diag(np.linalg.inv(info)))
    assert 0.5 * 0.02 / np.sqrt(3.0) < std[0] <= 0.02 / np.sqrt(3.0)
    assert std[1] < 0.005 and std[0] > 2.0 * std[1]


def _centre_patch(maps):
    """(prob, hits, mean_off, meta) of particle 0's 60 x 60 cells around the map's centre
    (0.05 m cells), read by the reference."""
    rows = int(maps.grid_meta[3])
    box = np.array([rows // 2 - 30, rows // 2 - 30, 60, 60], dtype=np.int64)
    prob, hits, mean_off = read_patch_ref(maps.dense(0), box)
    meta = np.array([maps.grid_meta[0] + box[1] * 0.05, maps.grid_meta[1] + box[0] * 0.05, 0.05,
                     *prob.shape])
    return prob, hits, mean_off, meta


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(3))
def test_read_patch_and_line_normal_equations_match_references(seed):
    rng = np.random.default_rng(seed)
    maps = TiledMaps(1, np.zeros(2), 2.0, 0.05, tile=8)
    for _ in range(3):
        pose = np.r_[rng.uniform(-0.3, 0.3, 2), rng.uniform(-np.pi, np.pi)]
        ends = _box_scan(rng, pose, beams=90, sigma=0.01)
        maps.insert(pose[None, :], ORIGIN, ends, rng.random(len(ends)) > 0.1)
    rows = int(maps.grid_meta[3])
    for box in ([10, 12, 41, 37], [-5, rows - 30, 47, 45], [rows // 2 - 30, rows // 2 - 30, 60, 60]):
        box = np.array(box, dtype=np.int64)
        # buffers larger than the box and full of stale values, as the proposal reuses them
        got = (np.full((70, 70), 7, np.float32), np.full((70, 70), 7, np.float32),
               np.full((70, 70, 2), 7, np.float32))
        read_patch(maps.tables[0], maps.pool, maps.grid_meta, box, box, *got)
        ref = read_patch_ref(maps.dense(0), box)
        for a, b in zip(got, ref):
            np.testing.assert_allclose(a[:box[2], :box[3]], b, atol=1e-5)
        # read inside a narrower box: the cells there as before, prob 0 around them
        inner = box + [7, 5, -15, -12]
        got[0][:] = 7
        read_patch(maps.tables[0], maps.pool, maps.grid_meta, box, inner, *got)
        rows_in, cols_in = slice(7, box[2] - 8), slice(5, box[3] - 7)
        for a, b in zip(got, ref):
            np.testing.assert_allclose(a[rows_in, cols_in], b[rows_in, cols_in], atol=1e-5)
        outside = np.ones(box[2:], bool)
        outside[rows_in, cols_in] = False
        assert np.all(got[0][:box[2], :box[3]][outside] == 0)
        assert np.any(ref[0][outside] > 0)
    prob, hits, mean_off, meta = _centre_patch(maps)
    pose = np.r_[rng.uniform(-0.2, 0.2, 2), rng.uniform(-np.pi, np.pi)]
    pts = _box_scan(rng, pose, beams=120, sigma=0.01)
    frees = _frees(pts)
    H, g, cost = line_normal_equations(prob, hits, mean_off, meta, 0.3, 1, pts, frees, pose)
    H_ref, g_ref, cost_ref = line_normal_equations_ref(prob, hits, mean_off, meta, 0.3, 1, pts,
                                                       frees, pose)
    np.testing.assert_allclose(H, H_ref, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(g, g_ref, rtol=1e-6, atol=1e-6)
    assert cost == pytest.approx(cost_ref, rel=1e-9)
    assert np.abs(g).sum() > 0      # the scan does read the map


@pytest.mark.kernel
def test_line_iterate_is_gn_update_on_fresh_normal_equations():
    """line_iterate keeps the walls' normals of the cells it met from one step to the next; it
    must take the steps that normal equations computed afresh at every pose give."""
    rng = np.random.default_rng(3)
    maps = TiledMaps(1, np.zeros(2), 2.0, 0.05, tile=8)
    for _ in range(4):
        pose = np.r_[rng.uniform(-0.3, 0.3, 2), rng.uniform(-np.pi, np.pi)]
        ends = _box_scan(rng, pose, beams=120, sigma=0.01)
        maps.insert(pose[None, :], ORIGIN, ends, np.ones(len(ends), bool))
    prob, hits, mean_off, meta = _centre_patch(maps)
    truth = np.r_[rng.uniform(-0.2, 0.2, 2), rng.uniform(-np.pi, np.pi)]
    pts = _box_scan(rng, truth, beams=120, sigma=0.01)
    frees = _frees(pts)
    start = truth + [0.03, -0.02, 0.02]
    prior, prior_info = start.copy(), np.diag([10.0, 10.0, 10.0])
    est, info = line_iterate(prob, hits, mean_off, meta, 0.3, 1, pts, frees, start, 6, 0.2,
                             prior, prior_info)
    want = start.copy()
    for _ in range(6):
        H, g, _ = line_normal_equations(prob, hits, mean_off, meta, 0.3, 1, pts, frees, want)
        if not gn_update(H, g, want, prior, prior_info, 0.2):
            break
    H, g, _ = line_normal_equations(prob, hits, mean_off, meta, 0.3, 1, pts, frees, want)
    add_prior(H, g, want, prior, prior_info)
    np.testing.assert_array_equal(est, want)
    np.testing.assert_array_equal(info, H)
    assert np.hypot(*(est[:2] - start[:2])) > 0.01      # it did move


def test_refinement_puts_the_wall_at_its_face_not_its_cell_centre():
    """A wall whose face lies 1.5 cm inside its cell (as in the rectangle worlds) is the only
    thing fixing x: measured to the lines through the mean hit points, the match ends within a
    few millimetres of the truth, not at the cell centre."""
    rng = np.random.default_rng(5)
    maps = TiledMaps(1, np.zeros(2), 5.0, 0.05, tile=16)
    half = (1.615, 1.115)       # faces at x = 1.615 (cell 1.60-1.65) and y = +-1.115

    def scan(pose):
        pts = _box_scan(rng, pose, half=half, sigma=0.005)
        near = np.hypot(*(pts - ORIGIN).T) < 1.4     # the wall at x = -1.615 stays out of range
        return pts[near]

    for x in np.linspace(0.6, 0.9, 8):
        pose = np.array([x, rng.uniform(-0.1, 0.1), rng.uniform(-0.2, 0.2)])
        ends = scan(pose)
        maps.insert(pose[None, :], ORIGIN, ends, np.ones(len(ends), bool))
    rows = int(maps.grid_meta[3])
    box = np.array([rows // 2 - 40, rows // 2 - 20, 80, 80], dtype=np.int64)
    no_prior = np.zeros(3)
    err = []
    for _ in range(8):
        truth = np.array([rng.uniform(0.65, 0.85), rng.uniform(-0.1, 0.1), rng.uniform(-0.2, 0.2)])
        pts = scan(truth)
        start = truth + np.r_[rng.uniform(-0.02, 0.02, 2), 0.0]
        est, _ = _refine(maps, box, pts, start, no_prior, no_prior)
        err.append(est[0] - truth[0])
    assert np.abs(np.mean(err)) < 0.003
    assert np.max(np.abs(err)) < 0.008
