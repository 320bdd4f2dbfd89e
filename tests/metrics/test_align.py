"""Alignment: ICP from a guess and the global search from nothing recover rigid transforms."""
import numpy as np
import pytest

from metrics.align import align_points, global_candidates, icp
from metrics.truth import prepare_truth
from slam.pose import compose, inverse, transform_points
from tests.metrics.maps import ROOM, draw
from worlds.grid import Grid
from worlds.yamlio import InputError

RES = 0.05


def random_room(rng):
    """An asymmetric room: outer walls of random size, 3-5 random inner walls, a random box."""
    w, h = rng.uniform(3.0, 7.0, 2)
    segs = [((0, 0), (w, 0)), ((w, 0), (w, h)), ((w, h), (0, h)), ((0, h), (0, 0))]
    for _ in range(rng.integers(3, 6)):
        a = rng.uniform([0.3, 0.3], [w - 0.3, h - 0.3])
        if rng.random() < 0.5:
            b = (rng.uniform(0.3, w - 0.3), a[1])
        else:
            b = (a[0], rng.uniform(0.3, h - 0.3))
        segs.append((tuple(a), b))
    cx, cy = rng.uniform([0.8, 0.8], [w - 0.8, h - 0.8])
    s = rng.uniform(0.15, 0.4)
    box = [(cx - s, cy - s), (cx + s, cy - s), (cx + s, cy + s), (cx - s, cy + s)]
    segs += [(box[i], box[(i + 1) % 4]) for i in range(4)]
    return segs


def rms_displacement(pose_a, pose_b, pts):
    return float(np.sqrt(np.mean(np.sum((transform_points(pose_a, pts) - transform_points(pose_b, pts)) ** 2, 1))))


def yaw_error_deg(a, b):
    return abs(np.rad2deg(np.angle(np.exp(1j * (a[2] - b[2])))))


def test_identity_stays_identity():
    t = prepare_truth(draw(ROOM))
    for mode in ("icp", "global", "none", "start"):
        al = align_points(t.points, t, mode, (0.0, 0.0, 0.0) if mode != "global" else None)
        np.testing.assert_allclose(al.pose, 0.0, atol=1e-9)
        assert al.inlier_fraction == 1.0


@pytest.mark.parametrize("seed", range(12))
def test_global_recovers_random_rigid_transforms(seed):
    rng = np.random.default_rng(seed)
    segs = random_room(rng)
    truth = prepare_truth(draw(segs))
    pose = np.array([*rng.uniform(-2.0, 2.0, 2), rng.uniform(-np.pi, np.pi)])
    est = draw(segs, pose=pose)  # the walls rasterized afresh in the moved frame
    pts = est.occupied_xy()
    al = align_points(pts, truth, "global", None)
    assert al.mode == "global"
    assert al.inlier_fraction > 0.99
    # both maps are rasterized from walls at random positions, each wall up to half a cell off
    # in each map, so the best fit of the cells may sit up to about a cell from the transform
    assert yaw_error_deg(al.pose, pose) < 0.5
    assert rms_displacement(al.pose, pose, truth.points) < 1.0 * RES
    # and the fit is as tight as ICP started at the true transform finds
    best, _ = icp(pts, truth, pose)
    assert al.rms_m < 1.25 * align_points(pts, truth, "start", best).rms_m


def test_global_candidates_contain_the_right_rotation():
    truth = prepare_truth(draw(ROOM))
    pose = np.array([0.4, -0.3, 2.0])
    est = draw(ROOM, pose=pose)
    cands = global_candidates(est.occupied_xy(), truth)
    assert min(yaw_error_deg(c, pose) for c in cands) <= 1.0


@pytest.mark.parametrize("guess", [(0.0, 0.0, 0.0), (0.1, 0.1, 0.05)])
def test_icp_from_a_guess(guess):
    truth = prepare_truth(draw(ROOM))
    centre = np.array([3.0, 2.5, 0.0])
    # 3 cells shift and 10 degrees about the room centre
    move = compose(compose(centre + [3 * RES, 0, 0], [0, 0, np.deg2rad(10)]), inverse(centre))
    est = draw(ROOM, pose=move)
    al = align_points(est.occupied_xy(), truth, "icp", guess)
    assert yaw_error_deg(al.pose, move) < 0.5
    assert rms_displacement(al.pose, move, truth.points) < 0.5 * RES


def test_auto_mode_and_bad_mode():
    t = prepare_truth(draw(ROOM))
    assert align_points(t.points, t, "auto", (0, 0, 0)).mode == "icp"
    assert align_points(t.points, t, "auto", None).mode == "global"
    with pytest.raises(InputError, match="unknown mode"):
        align_points(t.points, t, "bogus")
    with pytest.raises(InputError, match="start pose"):
        align_points(t.points, t, "start", None)


def test_start_mode_returns_the_prior():
    t = prepare_truth(draw(ROOM))
    al = align_points(t.points, t, "start", (0.2, 0.0, 0.1))
    np.testing.assert_array_equal(al.pose, [0.2, 0.0, 0.1])
    assert al.inlier_fraction < 1.0


@pytest.mark.parametrize("yaw_deg", [0.2, 0.4, -0.3, 1.0])
@pytest.mark.parametrize("est_res", [0.02, 0.01])
def test_icp_recovers_a_fraction_of_a_degree(yaw_deg, est_res):
    """An estimate on a finer grid whose frame is turned by tenths of a degree: point-to-point
    ICP snaps its cells onto the true cells 0.1 degree and 1 cm short (measured); the
    point-to-line finish recovers the turn. (With both maps on the same 0.05 m grid the cells
    themselves hold too little: a 0.3 degree turn moves a 9 m wall by half a cell.)"""
    room = [((0.0, 0.0), (9.0, 0.0)), ((9.0, 0.0), (9.0, 6.0)), ((9.0, 6.0), (0.0, 6.0)),
            ((0.0, 6.0), (0.0, 0.0)), ((3.0, 0.0), (3.0, 1.5))]
    truth = prepare_truth(draw(room))
    move = compose(compose([1.5, 1.0, 0.0], [0.012, -0.02, np.deg2rad(yaw_deg)]), inverse([1.5, 1.0, 0.0]))
    pts = draw(room, pose=move, resolution=est_res).occupied_xy()
    al = align_points(pts, truth, "icp", (0.0, 0.0, 0.0))
    assert yaw_error_deg(al.pose, move) < 0.03
    assert np.hypot(*(al.pose[:2] - move[:2])) < 0.004


def test_point_to_line_normals_of_a_straight_wall():
    t = prepare_truth(draw([((0.0, 0.0), (4.0, 0.0)), ((4.0, 0.0), (4.0, 3.0))]))
    normals, weight = t.normals()
    middle_of_bottom = (np.abs(t.points[:, 1]) < 0.03) & (t.points[:, 0] > 0.5) & (t.points[:, 0] < 3.5)
    assert middle_of_bottom.sum() > 50
    np.testing.assert_allclose(np.abs(normals[middle_of_bottom, 1]), 1.0, atol=1e-9)
    assert np.all(weight[middle_of_bottom] > 0.95)
    corner = np.hypot(t.points[:, 0] - 4.0, t.points[:, 1]) < 0.03
    assert np.all(weight[corner] < 0.8)


def _turned_room(seed, yaw):
    """(true segments (S, 4), the map of the room seen in a frame turned by `yaw` about the
    room's middle and moved by a few mm, that frame)."""
    rng = np.random.default_rng(seed)
    room = random_room(rng)
    segs = np.array([[*a, *b] for a, b in room])
    mid = np.append(segs[:, :2].mean(0), 0.0)
    move = compose(compose(mid, [*rng.uniform(-0.008, 0.008, 2), yaw]), inverse(mid))
    return segs, draw(room, pose=move), move


@pytest.mark.parametrize("yaw", [0.003, -0.005])
def test_surface_refinement_recovers_a_small_turn(yaw):
    """The truth turned by a few mrad and moved by millimetres: every cell it marks holds a
    surface, so under the right transform every occupied square touches one. ICP on cell
    centres stops where the quantisation balances (P 0.92-1.0 at tau 1 mm on these rooms);
    refined onto the surfaces the squares touch them (measured: P >= 0.992, S >= 0.996)."""
    from metrics.align import refine_to_surfaces
    from metrics.surface import classify_surface
    icp_p, got_p = [], []
    for seed in range(8):
        segs, est, move = _turned_room(seed, yaw)
        truth = prepare_truth(draw([((s[0], s[1]), (s[2], s[3])) for s in segs]))
        pts = est.occupied_xy()
        al = align_points(pts, truth, "icp", (0.0, 0.0, 0.0))
        pose, it = refine_to_surfaces(pts, segs, al.pose, RES)
        assert 0 < it <= 30
        assert classify_surface(est, segs, move, 0.001).portion.surface_precision == 1.0
        got = classify_surface(est, segs, pose, 0.001).portion
        before = classify_surface(est, segs, al.pose, 0.001).portion
        assert got.surface_precision >= 0.99 and got.surface_sensitivity >= 0.995
        assert got.surface_f1 >= before.surface_f1 - 1e-9
        icp_p.append(before.surface_precision)
        got_p.append(got.surface_precision)
    assert np.mean(icp_p) < 0.99 < 0.998 < np.mean(got_p)


def test_surface_refinement_ignores_stray_cells_and_needs_surfaces():
    """Cells off every surface (5 % and 10 % of the walls' count, at random in the free
    space) hardly pull the fit: at the default tau it scores within 0.005 of the exact
    transform. With no surfaces or fewer than 3 cells the pose comes back as given."""
    from metrics.align import refine_to_surfaces
    from metrics.surface import DEFAULT_TAU_M, classify_surface
    for seed, share in ((2, 0.05), (4, 0.1)):
        segs, est, move = _turned_room(seed, 0.004)
        rng = np.random.default_rng(seed)
        prob = est.prob.copy()
        free = np.argwhere(prob == 0.0)
        stray = free[rng.choice(len(free), size=int(share * np.sum(prob == 1.0)), replace=False)]
        prob[stray[:, 0], stray[:, 1]] = 1.0
        noisy = Grid(prob, est.resolution, est.origin)
        pts = noisy.occupied_xy()
        truth = prepare_truth(draw([((s[0], s[1]), (s[2], s[3])) for s in segs]))
        pose, _ = refine_to_surfaces(pts, segs, align_points(pts, truth, "icp", (0, 0, 0)).pose, RES)
        exact = classify_surface(noisy, segs, move, DEFAULT_TAU_M).portion
        got = classify_surface(noisy, segs, pose, DEFAULT_TAU_M).portion
        assert got.surface_f1 >= exact.surface_f1 - 0.005
    start = np.array([0.01, -0.02, 0.003])
    np.testing.assert_array_equal(refine_to_surfaces(pts, np.zeros((0, 4)), start, RES)[0], start)
    np.testing.assert_array_equal(refine_to_surfaces(pts[:2], segs, start, RES)[0], start)


def test_surface_refinement_of_a_single_wall_stays_put_along_it():
    """One straight wall defines no position along itself: the fit moves the map across onto
    the wall (the least move that makes its squares touch it) and, damped, not along it. A
    map whose squares are a whole cell off is left where it is: such cells are wrong, not
    misaligned."""
    from metrics.align import refine_to_surfaces
    from metrics.surface import classify_surface
    wall = np.array([[0.0, 0.013, 5.0, 0.013]])
    est = draw([((0.0, 0.013), (5.0, 0.013))])
    # the wall's cell spans y -0.025 .. 0.025: moved up by 0.04, its square misses by 2 mm
    start = np.array([0.0, 0.04, 0.0])
    assert classify_surface(est, wall, start, 0.001).portion.surface_precision == 0.0
    pose, _ = refine_to_surfaces(est.occupied_xy(), wall, start, RES)
    assert abs(pose[0]) < 1e-3 and abs(pose[2]) < 1e-4
    assert classify_surface(est, wall, pose, 0.001).portion.surface_precision == 1.0
    assert pose[1] == pytest.approx(0.038, abs=0.001)
    far = np.array([0.0, 0.09, 0.0])
    np.testing.assert_allclose(refine_to_surfaces(est.occupied_xy(), wall, far, RES)[0], far, atol=1e-6)


def _thickened(est, every):
    """`est` with every `every`-th wall cell doubled by the cell behind it as seen from the
    room's middle (outwards along the larger axis), as long-range returns draw some walls."""
    prob = est.prob.copy()
    rows, cols = np.nonzero(prob == 1.0)
    d = est.cell_to_world(rows, cols) - est.cell_to_world(rows, cols).mean(0)
    along_x = np.abs(d[:, 0]) > np.abs(d[:, 1])
    r = rows + np.where(along_x, 0, np.sign(d[:, 1])).astype(int)
    c = cols + np.where(along_x, np.sign(d[:, 0]), 0).astype(int)
    pick = (np.arange(len(rows)) % every == 0) & (r >= 0) & (c >= 0) & (r < prob.shape[0]) & (c < prob.shape[1])
    prob[r[pick], c[pick]] = 1.0
    return Grid(prob, est.resolution, est.origin)


@pytest.mark.parametrize("config, dragged", [({}, False), ({"surface_sigma_cells": 0.5}, True)])
def test_surface_refinement_is_not_dragged_by_walls_drawn_a_cell_thick(config, dragged):
    """Half the wall cells doubled by the cell behind them: those cells sit a cell off their
    surface. With sigma a tenth of a cell they cost the same wherever the map goes, so the fit
    keeps the right cells on their surfaces (F1 at the default tau never more than 0.01 below
    the exact transform's); a wide sigma (half a cell) lets them pull the map off."""
    from metrics.align import AlignConfig, refine_to_surfaces
    from metrics.surface import DEFAULT_TAU_M, classify_surface
    loss = []
    for seed in range(6):
        segs, est, move = _turned_room(seed, 0.004)
        thick = _thickened(est, 2)
        pts = thick.occupied_xy()
        truth = prepare_truth(draw([((s[0], s[1]), (s[2], s[3])) for s in segs]))
        start = align_points(pts, truth, "icp", (0.0, 0.0, 0.0)).pose
        pose, _ = refine_to_surfaces(pts, segs, start, RES, AlignConfig(**config))
        loss.append(classify_surface(thick, segs, move, DEFAULT_TAU_M).portion.surface_f1
                    - classify_surface(thick, segs, pose, DEFAULT_TAU_M).portion.surface_f1)
    assert (max(loss) > 0.01) == dragged, loss
