"""The pose-graph SLAM `graph` on short synthetic logs: mapping, loop closure, robustness."""
import dataclasses

import numpy as np
import pytest

from slam import registry
from slam.registry import load_config
from slam.replay import _iter_inputs
from slam.graph import GraphSlam
from slam.graph import loop_closure
from slam.graph.local import LocalSlam
from slam.graph.loop_closure import ConstraintBuilder, FixedRatioSampler, LoopConstraint, see_through_ratio
from slam.graph.scan_matching import ceres_match
from slam.graph.submaps import ActiveSubmaps, Submap
from slam.graph.tsdf import TsdfSubmap
from slam.graph.calibration import gyro_bias_from_yaw
from slam.graph.config import ConstraintBuilderConfig, SubmapsConfig
from slam.pose import interpolate_poses, relative, wrap_angle
from worlds.yamlio import InputError
from tests.slam.synthlog import box_room_segments, make_log, score, square_route, truth_grid

# Small submaps so that some finish (and are searched for loop closures) within a short log.
SMALL = {"trajectory_builder": {"submaps": {"num_range_data": 12}},
         "pose_graph": {"optimize_every_n_nodes": 20}}


@pytest.fixture(scope="module")
def room_log():
    return make_log(box_room_segments(), square_route(), seed=3)


def _ate(times, poses, log):
    gt = interpolate_poses(times, log.gt_t, log.gt_pose)
    return float(np.sqrt(np.mean(np.sum((poses[:, :2] - gt[:, :2]) ** 2, axis=1))))


def _run(log, cfg):
    s = GraphSlam(load_config("graph", cfg), log.start_pose.copy(), np.random.default_rng(0))
    for scan, odom, imu, _ in _iter_inputs(log):
        s.update(scan, odom, imu)
    return s


def test_registered_and_config_rejects_unknown_keys():
    assert registry.get("graph") is GraphSlam
    with pytest.raises(InputError, match="did you mean"):
        load_config("graph", {"pose_graph": {"optimize_every_n_node": 3}})
    with pytest.raises(InputError):
        load_config("graph", {"final_map": "pretty"})


def test_active_submaps_follow_cartographer():
    subs = ActiveSubmaps(SubmapsConfig(num_range_data=3))
    finished_at = {}
    for k in range(12):
        _, created, finished = subs.insert(np.zeros(2), np.array([[1.0, 0.0]]), np.zeros((0, 2)))
        for f in finished:
            finished_at[f] = k
    # each finished submap holds 2 * num_range_data scans, two are active at a time
    assert all(subs.all[i].num_range_data == 6 for i in finished_at)
    assert len(subs.active) == 2 and finished_at[0] == 5 and finished_at[1] == 8


def test_fixed_ratio_sampler():
    s = FixedRatioSampler(0.3)
    picks = [s.pulse() for _ in range(100)]
    assert sum(picks) == 30 and picks[0]


def test_maps_room_and_closes_loop(room_log):
    s = _run(room_log, SMALL)
    s.finish()
    g = s.graph
    assert len(g.loops) > 0                               # loop closure fired
    # every accepted loop closure agrees with the optimized graph to within a few cm
    t, poses = s.trajectory()
    for c in g.loops:
        # submap frame -> world: the submap's global pose and its local pose differ by the correction
        node_from_submap = relative(g.submap_global[c.submap], g.node_global[c.node])
        assert np.hypot(*(node_from_submap[:2] - c.z[:2])) < 0.05
    assert _ate(t, poses, room_log) < 0.03
    p, sens = score(s.map(), truth_grid(box_room_segments()))
    assert p > 0.9 and sens > 0.9


def test_finish_closes_loops_of_the_submaps_still_being_built(room_log):
    s = _run(room_log, SMALL)
    g = s.graph
    active = [sm.index for sm in s.local.submaps.active]
    assert active and not any(c.submap in active for c in g.loops)
    n_opt = g.n_optimizations
    s.finish()
    assert all(i in g.builder.matchers for i in active) and g.n_optimizations == n_opt + 1
    new = [c for c in g.loops if c.submap in active]
    # older nodes (not inserted into that submap) matched against it, as for a finished submap
    assert new and all(c.submap not in g.node_submaps[c.node] for c in new)
    for c in new:
        found = relative(g.submap_global[c.submap], g.node_global[c.node])
        assert np.hypot(*(found[:2] - c.z[:2])) < 0.05


@pytest.mark.parametrize("opt, robust", [({}, True), ({"max_loop_residual": 0.0}, True),
                                         ({"huber_scale": 1e12, "max_loop_residual": 0.0}, False)])
def test_wrong_loop_closure_does_not_wreck_result(room_log, opt, robust):
    # Huber alone (no residual check) must hold; with neither the same closure wrecks the map,
    # which shows this test can fail.
    cfg = {**SMALL, "pose_graph": {**SMALL["pose_graph"], "optimization_problem": opt}}
    s = _run(room_log, cfg)
    g = s.graph
    # a confident, wildly wrong closure: the last node seen 1.5 m off in the first submap
    truth_z = relative(g.submaps[0].local_pose, g.node_local[-1])
    for k in range(3):
        g.loops.append(LoopConstraint(0, len(g.node_local) - 1 - k, truth_z + [1.5, -1.0, 0.5], 0.95))
    s.finish()
    t, poses = s.trajectory()
    assert (_ate(t, poses, room_log) < 0.05) == robust


def test_submap_free_space_stops_the_range_noise_band_short_of_a_hit():
    hit = np.array([[3.0, 0.0]])        # a wall 3 m ahead: sigma 7.5 cm at 2.5 % of the range
    origin = np.zeros(2)
    cells = {}
    for k in (0.0, 2.6):
        s = ActiveSubmaps(SubmapsConfig(grid_type="probability_grid", free_space_margin_sigmas=k))
        s.insert(origin, hit, np.zeros((0, 2)))
        grid = s.all[0].grid
        xs = np.arange(0.025, 3.0, 0.05)
        r = np.floor((0.0 - grid.origin[1]) / grid.resolution).astype(int)
        c = np.floor((xs - grid.origin[0]) / grid.resolution).astype(int)
        cells[k] = grid.logodds[r, c]
    # without the margin every cell before the hit is freed; with 2.6 sigma (19.5 cm) the last
    # free point is at 2.805 m, in the cell [2.80, 2.85): the three cells after it are only
    # observed (log-odds 0), the rest freed as before
    assert np.all(cells[0.0] < 0)
    assert np.all(cells[2.6][:-3] < 0) and np.all(cells[2.6][-3:] == 0.0)
    np.testing.assert_array_equal(cells[2.6][:-3], cells[0.0][:-3])


def test_submap_config_rejects_a_negative_margin():
    with pytest.raises(ValueError, match="free_space_margin_sigmas"):
        SubmapsConfig(free_space_margin_sigmas=-1.0)


# A 0.12 m thin wall between x = 1.02 and x = 1.14, mapped only from its left (from x = 0), and a
# scan from x = 2 that sees its right face: at the true pose the scan lands on the unmapped right
# face; 0.12 m to the left it lands on the mapped left face, with free space seen behind it.
WALL_YS = np.linspace(-0.5, 0.5, 41)
RIGHT_FACE_SCAN = np.column_stack([np.full(len(WALL_YS), 1.14 - 2.0), WALL_YS])   # robot frame
TRUE_POSE = np.array([2.0, 0.0, 0.0])
FAR_FACE_POSE = np.array([1.88, 0.0, 0.0])


def _left_face_submap():
    sub = Submap(0, np.zeros(2), SubmapsConfig(free_space_margin_sigmas=0.0))
    for y0 in np.linspace(-0.3, 0.3, 30):
        sub.insert(np.array([0.0, y0]), np.column_stack([np.full(len(WALL_YS), 1.02), WALL_YS]),
                   np.zeros((0, 2)))
    return sub


def test_see_through_ratio_flags_the_far_face_of_a_thin_wall():
    sub = _left_face_submap()
    origin = np.zeros(2)
    assert see_through_ratio(sub, RIGHT_FACE_SCAN, origin, TRUE_POSE, 0.3) == 0.0
    assert see_through_ratio(sub, RIGHT_FACE_SCAN, origin, FAR_FACE_POSE, 0.3) > 0.9
    # nothing behind the points has been seen at all: no evidence against the match
    assert see_through_ratio(sub, RIGHT_FACE_SCAN + [5.0, 0.0], origin, TRUE_POSE, 0.3) == 0.0


@pytest.mark.parametrize("check", [True, False])
def test_loop_closure_on_the_far_face_of_a_thin_wall_is_rejected(check):
    sub = _left_face_submap()
    sub.finished = True
    # the other rejection tests off: a straight wall pins only x, so they would reject it first
    cfg = ConstraintBuilderConfig(sampling_ratio=1.0, min_information_ratio=0.0, ambiguity_radius=0.0,
                                  max_see_through_ratio=0.05 if check else 0.0)
    builder = ConstraintBuilder(cfg)
    builder.add_finished_submap(sub)
    found = builder.compute(sub, sub.local_pose, 0, TRUE_POSE, RIGHT_FACE_SCAN, np.zeros(2))
    if check:
        assert found is None and builder.see_through == 1
    else:
        # the hit-only score puts the scan on the mapped (left) face, 12 cm from the truth
        assert found is not None and abs(found.z[0] - FAR_FACE_POSE[0]) < 0.03


def test_constraint_builder_config_rejects_a_bad_see_through_ratio():
    with pytest.raises(ValueError, match="max_see_through_ratio"):
        ConstraintBuilderConfig(max_see_through_ratio=1.5)


# A straight corridor 1.05 m wide along x (walls on cell centres), mapped from its middle, and a
# scan that sees 3 m of both walls: any shift along the corridor scores the same.
CORRIDOR_XS = np.linspace(-1.5, 1.5, 61)


def _corridor_submap():
    sub = Submap(0, np.zeros(2), SubmapsConfig(free_space_margin_sigmas=0.0))
    xs = np.linspace(-4.0, 4.0, 161)
    for x0 in np.linspace(-2.0, 2.0, 9):
        walls = np.vstack([np.column_stack([xs, np.full(len(xs), y)]) for y in (-0.525, 0.525)])
        sub.insert(np.array([x0, 0.0]), walls[np.abs(walls[:, 0] - x0) < 3.0], np.zeros((0, 2)))
    sub.finished = True
    return sub


def test_a_corridor_loop_closure_pins_only_the_side_position_and_heading():
    sub = _corridor_submap()
    truth = np.array([0.3, 0.03, 0.02])
    c, s = np.cos(truth[2]), np.sin(truth[2])
    world = np.vstack([np.column_stack([CORRIDOR_XS + truth[0], np.full(len(CORRIDOR_XS), y)])
                       for y in (-0.525, 0.525)])
    scan = (world - truth[:2]) @ np.array([[c, -s], [s, c]])      # robot frame of the true pose
    guess = np.array([0.1, 0.08, 0.0])       # the graph's current estimate: 0.2 m behind, 5 cm off

    def closure(checks):
        cfg = ConstraintBuilderConfig(sampling_ratio=1.0, min_information_ratio=0.1 if checks else 0.0,
                                      ambiguity_radius=0.3 if checks else 0.0)
        builder = ConstraintBuilder(cfg)
        builder.add_finished_submap(sub)
        return builder, builder.compute(sub, sub.local_pose, 0, guess, scan, np.zeros(2))

    _, plain = closure(False)
    builder, slide = closure(True)
    # both checks off: an ordinary constraint, at whatever place along the corridor the search
    # found (here 5 cm past the estimate)
    assert plain.slide_axis is None and abs(plain.z[0] - guess[0]) > 0.04
    # with them, the match slides: it weighs nothing along the corridor (x), in the node's frame
    assert slide.slide_axis is not None and builder.sliding == 1
    assert abs(np.sin(slide.slide_axis + slide.z[2])) < 0.05
    # across the corridor and in heading it says what the ordinary match says, near the truth
    np.testing.assert_allclose(slide.z[1:], plain.z[1:], atol=0.003)
    np.testing.assert_allclose(slide.z[1:], truth[1:], atol=0.01)
    # along it, it keeps the current estimate rather than the search's guess
    assert abs(slide.z[0] - guess[0]) < 0.02


# A corridor closed at x = -1 (walls y = +-0.6), mapped into a TSDF submap from x = -0.5..0.3 out
# to 1.8 m, and a node at x = 1.4 that sees 3 m: 40 % of its points lie on cells the submap never
# saw, whose never-observed value pulls them back into the submap.
CLOSED_CORRIDOR = [(-1.0, 0.6, 5.0, 0.6), (-1.0, -0.6, 5.0, -0.6), (-1.0, -0.6, -1.0, 0.6)]


def _segment_points(origin, max_range, step):
    out = []
    for x0, y0, x1, y1 in CLOSED_CORRIDOR:
        n = int(np.hypot(x1 - x0, y1 - y0) / step) + 1
        p = np.column_stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n)])
        out.append(p[np.hypot(*(p - origin).T) < max_range])
    return np.vstack(out)


def test_loop_closure_refinement_leaves_out_points_the_submap_never_saw(monkeypatch):
    sub = TsdfSubmap(0, np.array([-0.5, 0.0]), SubmapsConfig())
    for x0 in np.linspace(-0.5, 0.3, 9):
        sub.insert(np.array([x0, 0.0]), _segment_points(np.array([x0, 0.0]), 1.8, 0.01), np.zeros((0, 2)))
    sub.finished = True
    truth = np.array([1.4, 0.02, 0.01])
    c, s = np.cos(truth[2]), np.sin(truth[2])
    scan = (_segment_points(truth[:2], 3.0, 0.03) - truth[:2]) @ np.array([[c, -s], [s, c]])
    guess = truth + np.array([0.04, -0.03, 0.01])
    cfg = ConstraintBuilderConfig(sampling_ratio=1.0, min_score=0.3, min_information_ratio=0.0,
                                  ambiguity_radius=0.0, max_see_through_ratio=0.0)
    seen = loop_closure.seen_weights(sub, scan, truth)
    assert 0.3 < 1.0 - seen.mean() < 0.5 and set(np.unique(seen)) == {0.0, 1.0}
    # the refinement alone, from the estimate: weighted, it lands on the truth; unweighted, the
    # unseen points drag the node 9 mm back towards the submap's origin (-x)
    prob, meta = sub.probabilities()
    weighted = ceres_match(prob, meta, scan, guess, guess, cfg.ceres_scan_matcher,
                           loop_closure.seen_weights(sub, scan, guess))
    plain = ceres_match(prob, meta, scan, guess, guess, cfg.ceres_scan_matcher)
    assert abs(weighted[0] - truth[0]) < 0.002
    assert plain[0] - truth[0] < -0.006

    # the constraint builder refines that way: its closure lies nearer the truth along x
    def closure():
        builder = ConstraintBuilder(cfg)
        builder.add_finished_submap(sub)
        return builder.compute(sub, sub.local_pose, 0, guess, scan, np.zeros(2))

    along = closure().z[0] - relative(sub.local_pose, truth)[0]
    monkeypatch.setattr(loop_closure, "seen_weights", lambda submap, points, pose: np.ones(len(points)))
    along_plain = closure().z[0] - relative(sub.local_pose, truth)[0]
    assert abs(along) < abs(along_plain) - 0.003


def test_local_slam_learns_a_constant_gyro_bias(room_log):
    # 0.005 rad/s added to every gyro sample: the matcher's pull to the prediction passes much
    # of it into the yaw; learned from the matcher's corrections it is taken back out
    bias = 0.005
    biased = dataclasses.replace(room_log, imu_gyro=room_log.imu_gyro + bias)
    late_yaw_error = {}
    for tau in (0.0, 10.0):
        cfg = {"trajectory_builder": {"gyro_bias_time_constant": tau},
               "pose_graph": {"enable_loop_closure": False}}
        s = _run(biased, cfg)
        t, poses = s.trajectory()
        gt = interpolate_poses(t, room_log.gt_t, room_log.gt_pose)
        yaw_error = np.abs(wrap_angle(poses[:, 2] - gt[:, 2]))
        late_yaw_error[tau] = float(np.mean(yaw_error[len(t) // 2:]))
        if tau > 0:
            assert s.local.gyro_bias == pytest.approx(bias, rel=0.2)
        else:
            assert s.local.gyro_bias == 0.0
    assert late_yaw_error[10.0] < 0.5 * late_yaw_error[0.0]


def test_the_gyro_bias_is_learned_from_turning_scans_too(room_log, monkeypatch):
    # the square route's corners: on a route into new ground the scans of a turn, which see
    # walls inserted long before, are where a bias shows most, so they are not left out
    rates = []
    learn = LocalSlam._learn_gyro_bias

    def record(self, correction):
        if self.prev_t is not None and self.t > self.prev_t:   # the yaw rate of the scan before
            rates.append(abs(wrap_angle(self.pose[2] - self.prev_pose[2])) / (self.t - self.prev_t))
        learn(self, correction)

    monkeypatch.setattr(LocalSlam, "_learn_gyro_bias", record)
    _run(room_log, {"pose_graph": {"enable_loop_closure": False}})
    rates = np.array(rates)
    assert (rates > 0.3).sum() >= 10 and (rates < 0.05).sum() >= 10


def test_local_config_rejects_a_negative_gyro_bias_time_constant():
    with pytest.raises(InputError, match="gyro_bias_time_constant"):
        load_config("graph", {"trajectory_builder": {"gyro_bias_time_constant": -1.0}})


def test_calibrate_gyro_reads_the_bias_and_runs_the_log_again(room_log):
    # 0.003 rad/s added to the gyro, not learned online: the first run's yaw, held by the
    # room's walls and loop closures, shows it; the second run takes it out
    bias = 0.003
    biased = dataclasses.replace(room_log, imu_gyro=room_log.imu_gyro + bias)
    it, gyro = room_log.imu_t, room_log.imu_gyro
    true_yaw = np.interp(it, room_log.gt_t, np.unwrap(room_log.gt_pose[:, 2]))
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (gyro[1:] + gyro[:-1]) * np.diff(it))])
    own = gyro_bias_from_yaw(it, true_yaw, integral)     # the log's own gyro error
    late_yaw_error = {}
    for calibrate in (False, True):
        cfg = {**SMALL, "trajectory_builder": {**SMALL["trajectory_builder"], "gyro_bias_time_constant": 0.0},
               "calibrate_gyro": calibrate}
        s = _run(biased, cfg)
        s.finish()
        t, poses = s.trajectory()
        assert len(t) == biased.n_scans
        gt = interpolate_poses(t, room_log.gt_t, room_log.gt_pose)
        late_yaw_error[calibrate] = float(np.mean(np.abs(wrap_angle(poses[:, 2] - gt[:, 2]))[len(t) // 2:]))
        if calibrate:
            # the first run's yaw still carries part of the drift: most of the bias, not all
            assert 0.5 * bias < s.calibrated_gyro_bias - own < 1.1 * bias
            assert s.extra_stats()["calibrated_gyro_bias_rad_s"] == s.calibrated_gyro_bias
            assert s.local.cfg.ceres_scan_matcher.rotation_weight == 1000.0
            assert s.map().prob.shape[0] > 0
        else:
            assert s.calibrated_gyro_bias is None and "calibrated_gyro_bias_rad_s" not in s.extra_stats()
    assert late_yaw_error[True] < 0.5 * late_yaw_error[False]


def test_calibrate_gyro_keeps_the_first_run_without_the_gyro(room_log):
    cfg = {**SMALL, "trajectory_builder": {**SMALL["trajectory_builder"], "use_imu_data": False},
           "calibrate_gyro": True}
    s = _run(room_log, cfg)
    s.finish()
    assert s.calibrated_gyro_bias is None and len(s.trajectory()[0]) == room_log.n_scans
