"""graph's correlative search: the yaw innovation it reports, and the rotation penalty that local
SLAM sets from the spread of those innovations."""
import dataclasses

import numpy as np
import pytest

from slam.graph.config import LocalConfig, RealTimeCorrelativeConfig
from slam.graph.local import MIN_INNOVATIONS, LocalSlam
from slam.graph.scan_matching import real_time_correlative_match

RES = 0.05


def _room_grid():
    """A 4 x 3 m room with a pillar, as a probability grid (walls 0.9, elsewhere 0.1)."""
    rows, cols = 80, 100
    prob = np.full((rows, cols), 0.1)
    prob[[5, 74], 5:95] = 0.9
    prob[5:75, [5, 94]] = 0.9
    prob[30:36, 60:66] = 0.9
    meta = np.array([0.0, 0.0, RES, rows, cols])
    return prob, meta


def _scan_of(prob, meta, pose):
    """Robot-frame points of the grid's wall cells within 3 m of `pose`."""
    r, c = np.nonzero(prob > 0.5)
    world = np.stack([meta[0] + (c + 0.5) * RES, meta[1] + (r + 0.5) * RES], axis=1)
    c_, s_ = np.cos(pose[2]), np.sin(pose[2])
    d = world - pose[:2]
    local = np.stack([c_ * d[:, 0] + s_ * d[:, 1], -s_ * d[:, 0] + c_ * d[:, 1]], axis=1)
    keep = np.hypot(local[:, 0], local[:, 1]) < 3.0
    return local[keep][::2]


@pytest.mark.parametrize("weight", [0.1, 1e4])
def test_the_yaw_innovation_is_what_the_scan_alone_prefers(weight):
    prob, meta = _room_grid()
    truth = np.array([2.02, 1.48, 0.3])
    points = _scan_of(prob, meta, truth)
    off = np.radians(4.0)
    pred = truth + np.array([0.0, 0.0, off])
    cfg = RealTimeCorrelativeConfig(angular_search_window=np.radians(10.0))
    found = real_time_correlative_match(prob, meta, points, pred, cfg, rotation_delta_cost_weight=weight)
    # the innovation ignores the penalty: the scan's own preference, back to the truth
    assert found.yaw_innovation == pytest.approx(-off, abs=2 * found.angular_step)
    assert found.angular_step < np.radians(2.0)
    if weight < 1:
        assert found.pose[2] == pytest.approx(truth[2], abs=2 * found.angular_step)
    else:      # a penalty this strong holds the prediction's yaw
        assert found.pose[2] == pytest.approx(pred[2], abs=1e-12)


def _local(gain=0.005, weight=0.1):
    rt = RealTimeCorrelativeConfig(rotation_delta_cost_weight=weight, rotation_delta_cost_gain=gain)
    cfg = dataclasses.replace(LocalConfig(), real_time_correlative_scan_matcher=rt)
    return LocalSlam(cfg, np.zeros(3))


def _fill(local, innovations, step):
    local.yaw_innovations.extend(innovations)
    local.innovation_floor = step


def test_the_penalty_follows_the_spread_of_the_yaw_innovations():
    rng = np.random.default_rng(0)
    step = np.radians(0.05)
    sigma = np.radians(0.5)         # good odometry: the scans confirm its yaw to half a degree
    local = _local()
    _fill(local, rng.normal(0, sigma, MIN_INNOVATIONS - 1), step)
    assert local._rotation_delta_cost_weight() == 0.1      # too few innovations yet
    _fill(local, rng.normal(0, sigma, 200), step)
    assert local._rotation_delta_cost_weight() == pytest.approx(0.005 / sigma, rel=0.25)
    # raw odometry (6 degrees): the configured weight is the floor
    raw = _local()
    _fill(raw, rng.normal(0, np.radians(6.0), 200), step)
    assert raw._rotation_delta_cost_weight() == 0.1
    # innovations all within one step: sigma is the step, not zero
    exact = _local()
    _fill(exact, np.zeros(50), step)
    assert exact._rotation_delta_cost_weight() == pytest.approx(0.005 / step)
    # gain 0: Cartographer's fixed weight
    off = _local(gain=0.0)
    _fill(off, rng.normal(0, sigma, 200), step)
    assert off._rotation_delta_cost_weight() == 0.1


def test_the_penalty_follows_the_recent_route():
    # odometry that turns bad: only the last INNOVATION_WINDOW innovations count
    rng = np.random.default_rng(1)
    local = _local()
    _fill(local, rng.normal(0, np.radians(0.3), 300), np.radians(0.05))
    good = local._rotation_delta_cost_weight()
    _fill(local, rng.normal(0, np.radians(6.0), local.yaw_innovations.maxlen), np.radians(0.05))
    assert good > 0.5 and local._rotation_delta_cost_weight() == 0.1


def _yaw_weight_after(log):
    from slam.graph import GraphSlam
    from slam.registry import load_config
    from slam.replay import _iter_inputs
    cfg = {"trajectory_builder": {"use_online_correlative_scan_matching": True, "use_imu_data": False},
           "pose_graph": {"enable_loop_closure": False}}
    s = GraphSlam(load_config("graph", cfg), log.start_pose.copy(), np.random.default_rng(0))
    for scan, odom, imu, _ in _iter_inputs(log):
        s.update(scan, odom, imu)
    return s.local._rotation_delta_cost_weight(), len(s.local.yaw_innovations)


def test_a_run_learns_the_penalty_from_how_well_the_odometry_turns():
    from tests.slam.synthlog import box_room_segments, make_log, square_route
    log = make_log(box_room_segments(), square_route(), seed=3)
    good, n = _yaw_weight_after(log)
    # the same log with the odometry's heading off by a random walk of about 3 degrees per scan
    rng = np.random.default_rng(0)
    per_sample = np.radians(3.0) / np.sqrt(0.2 / np.median(np.diff(log.odom_t)))
    odom = log.odom_pose.copy()
    odom[:, 2] += np.cumsum(rng.normal(0, per_sample, len(odom)))
    bad, _ = _yaw_weight_after(dataclasses.replace(log, odom_pose=odom))
    assert n > MIN_INNOVATIONS
    # good: the innovations stay within the search's angular step (0.05 m at 3.5 m: 0.8 degree)
    assert good == pytest.approx(0.005 / (0.05 / 3.5), rel=0.1)
    assert bad == 0.1
