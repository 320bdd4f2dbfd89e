"""ROS export stamps (sim.logs.ros_export): integer nanoseconds, a real epoch recorded on /log_epoch and
taken off again on import, the TurtleBot3 Burger's heights in /tf_static."""
import dataclasses

import numpy as np
import pytest

pytest.importorskip("rosbags")

from sim.__main__ import main as sim_main  # noqa: E402
from sim.logs import SensorLog, export_bag, import_bag, write_log  # noqa: E402
from sim.logs.ros_export import DEFAULT_EPOCH  # noqa: E402
from sim.logs.ros_msgs import EPOCH_TOPIC  # noqa: E402

STREAMS = {"scan_t": "/scan", "odom_t": "/odom", "imu_t": "/imu", "gt_t": "/ground_truth"}
LEAN = 2.9999999999996   # a time just under a whole second: a float split once made it 2 s 0 ns


def cumsum_log() -> SensorLog:
    """A small log whose times are cumulative sums (0.1 s scans, 0.01 s IMU) that fall just
    below whole seconds (4.999999999999998, 2.99999999999998), odometry holding LEAN."""
    scan_t = np.cumsum(np.full(60, 0.1))
    odom_t = scan_t.copy()
    odom_t[29] = LEAN
    imu_t = np.cumsum(np.full(600, 0.01))
    pose = np.stack([0.01 * np.arange(60), np.zeros(60), np.zeros(60)], axis=1)
    return SensorLog(scan_t=scan_t, scan_ranges=np.full((60, 8), 2.0),
                     scan_angles=np.linspace(-1.0, 1.0, 8), odom_t=odom_t, odom_pose=pose,
                     odom_twist=np.zeros((60, 2)), imu_t=imu_t, imu_gyro=np.zeros(600),
                     imu_accel=np.zeros((600, 2)), imu_yaw=np.zeros(600), gt_t=odom_t, gt_pose=pose,
                     meta={"lidar": {"range_min": 0.1, "range_max": 3.5, "offset": [-0.032, 0.0, 0.0]}})


def _bag_path(tmp_path, fmt):
    return tmp_path / ("b.bag" if fmt == "ros1" else "b")


def _header_stamps(path) -> dict[str, list[int]]:
    """topic -> header stamps (ns) in bag order, read with rosbags, not sim.logs."""
    from rosbags.highlevel import AnyReader
    out: dict[str, list[int]] = {}
    with AnyReader([path]) as reader:
        for conn, _, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            if hasattr(msg, "header"):
                out.setdefault(conn.topic, []).append(msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec)
    return out


def _messages(path, topic):
    from rosbags.highlevel import AnyReader
    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        return [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]


def _ns(t):
    return np.round(np.asarray(t) * 1e9).astype(np.int64)


@pytest.mark.parametrize("fmt", ["ros1", "ros2", "mcap"])
def test_stamps_are_the_epoch_plus_each_time_to_the_nearest_ns(tmp_path, fmt):
    log = cumsum_log()
    stamps = _header_stamps(export_bag(log, _bag_path(tmp_path, fmt), fmt))
    for name, topic in STREAMS.items():
        got = np.array(stamps[topic], dtype=np.int64)
        np.testing.assert_array_equal(got, DEFAULT_EPOCH * 10**9 + _ns(getattr(log, name)), err_msg=topic)
        assert np.all(np.diff(got) > 0), topic
    assert stamps["/odom"][29] == (DEFAULT_EPOCH + 3) * 10**9


@pytest.mark.parametrize("fmt", ["ros1", "ros2", "mcap"])
def test_import_gives_back_every_time_to_the_ns(tmp_path, fmt):
    log = cumsum_log()
    back = import_bag(export_bag(log, _bag_path(tmp_path, fmt), fmt, epoch=1_234_567_890))
    for name in STREAMS:
        np.testing.assert_array_equal(_ns(getattr(back, name)), _ns(getattr(log, name)), err_msg=name)
    assert back.meta["source"]["epoch_ns"] == 1_234_567_890 * 10**9
    assert back.meta["import_warnings"] == []


def test_the_epoch_is_on_its_topic_and_starts_the_bag(tmp_path):
    out = export_bag(cumsum_log(), tmp_path / "b.bag", "ros1", epoch=1_600_000_000)
    [epoch] = _messages(out, EPOCH_TOPIC)
    assert epoch.data == 1_600_000_000 * 10**9
    from rosbags.highlevel import AnyReader
    with AnyReader([out]) as reader:
        assert reader.start_time == 1_600_000_000 * 10**9 + 10_000_000   # the IMU's first, 0.01 s


def test_tf_static_has_the_burger_heights(tmp_path):
    [msg] = _messages(export_bag(cumsum_log(), tmp_path / "b", "mcap"), "/tf_static")
    tf = {(t.header.frame_id, t.child_frame_id): t.transform.translation for t in msg.transforms}
    base, scan = tf[("base_footprint", "base_link")], tf[("base_link", "base_scan")]
    assert (base.x, base.y, base.z) == (0.0, 0.0, 0.010)
    assert (scan.x, scan.y, scan.z) == (-0.032, 0.0, 0.172)
    assert tf[("base_link", "imu_link")].z == 0.068


def _shifted(log: SensorLog, dt: float) -> SensorLog:
    return dataclasses.replace(log, **{name: getattr(log, name) + dt for name in STREAMS})


@pytest.mark.parametrize("fmt, epoch", [("ros1", 0), ("ros1", 2**32 - 5), ("ros2", 2**31 - 5), ("mcap", 10**30)])
def test_stamps_outside_ros_time_are_one_line(tmp_path, capsys, fmt, epoch):
    """Stamp 0 is "no time"; ROS 1 seconds are uint32, ROS 2's int32 (the log ends at 6 s)."""
    write_log(_shifted(cumsum_log(), -0.01), tmp_path / "log.npz")   # the IMU starts at 0
    code = sim_main(["export", str(tmp_path / "log.npz"), "--format", fmt, "--out",
                     str(_bag_path(tmp_path, fmt)), "--epoch", str(epoch)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("error: --epoch: ")
    assert not _bag_path(tmp_path, fmt).exists()


def test_cli_epoch_flag_and_default(tmp_path, capsys):
    write_log(cumsum_log(), tmp_path / "log.npz")
    assert sim_main(["export", str(tmp_path / "log.npz"), "--format", "mcap", "--out", str(tmp_path / "a")]) == 0
    assert sim_main(["export", str(tmp_path / "log.npz"), "--format", "mcap", "--out", str(tmp_path / "b"),
                     "--epoch", "1000"]) == 0
    assert _header_stamps(tmp_path / "a")["/scan"][0] == DEFAULT_EPOCH * 10**9 + 100_000_000
    assert _header_stamps(tmp_path / "b")["/scan"][0] == 1000 * 10**9 + 100_000_000
    assert sim_main(["import", str(tmp_path / "b"), "--out", str(tmp_path / "back.npz")]) == 0
    assert capsys.readouterr().err == ""
    with pytest.raises(SystemExit):
        sim_main(["export", "--help"])
    assert str(DEFAULT_EPOCH) in capsys.readouterr().out
