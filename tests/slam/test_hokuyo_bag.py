"""A ROS bag of a 270-degree Hokuyo (a UTM-30LX recorded by the simulator and written as a
ROS 1 bag) imports and maps with every algorithm's defaults, derived from the bag's scans."""
import math

import numpy as np
import pytest

pytest.importorskip("rosbags")

from bench.task import score_trajectory  # noqa: E402
from sim.logs import export_bag, import_bag  # noqa: E402
from slam.registry import explain_config  # noqa: E402
from slam.replay import run_algorithm  # noqa: E402


@pytest.fixture(scope="module")
def bag_log(tmp_path_factory):
    import sim
    import worlds
    log = sim.record(worlds.load_world("rectangle_s"), seed=4, lidar="utm-30lx")
    path = export_bag(log, tmp_path_factory.mktemp("bag") / "hokuyo.bag", "ros1")
    return path, import_bag(path)


def test_the_bag_holds_the_hokuyo_laserscan_fields(bag_log):
    from rosbags.highlevel import AnyReader
    path, _ = bag_log
    with AnyReader([path]) as reader:
        conn = [c for c in reader.connections if c.topic == "/scan"]
        _, _, raw = next(reader.messages(connections=conn))
        msg = reader.deserialize(raw, conn[0].msgtype)
    assert msg.angle_min == pytest.approx(-math.radians(135.0), abs=1e-6)
    assert msg.angle_max == pytest.approx(math.radians(135.0), abs=1e-6)
    assert msg.angle_increment == pytest.approx(math.radians(0.25), rel=1e-6)
    assert msg.time_increment == pytest.approx(0.025 / 1440, rel=1e-5)
    assert msg.scan_time == pytest.approx(0.025) and msg.range_max == pytest.approx(30.0)
    assert len(msg.ranges) == 1081


def test_the_bag_maps_with_defaults(bag_log):
    _, log = bag_log
    assert log.scan_ranges.shape[1] == 1081 and log.has_odometry and log.has_ground_truth
    derived = {d.path: d.value for d, _ in explain_config("graph", None, log)}
    assert derived["trajectory_builder.max_range"] == pytest.approx(30.0)
    assert derived["trajectory_builder.motion_filter.max_angle_radians"] == pytest.approx(
        math.radians(0.8), rel=1e-3)
    for algo in ("graph", "pf", "gn"):
        r = run_algorithm(algo, log, seed=0)
        ate = score_trajectory(r.times, r.poses, log.gt_t, log.gt_pose)["ate_m"]
        assert ate < 0.03, f"{algo}: ATE {ate:.3f} m"
        assert (np.nan_to_num(r.grid.prob, nan=0.5) > 0.5).sum() > 50   # nan: unknown cells
