"""Importing bags from elsewhere (sim.logs.ros_import, `python -m sim import`): ROS 1 frames
with a leading slash, several scan topics, header stamps out of order, --out kept without
--force."""
import numpy as np
import pytest

pytest.importorskip("rosbags")

from sim.__main__ import main as sim_main  # noqa: E402
from sim.logs import import_bag  # noqa: E402
from sim.logs.ros_msgs import typestore  # noqa: E402
from worlds.yamlio import InputError  # noqa: E402


def _ros1_bag(path, scans=None, slash="", tf_odom=True, epoch=None):
    """A ROS 1 bag as ROS 1 drivers write it: `scans` maps a topic to its header stamps (s, in
    bag order); frames prefixed with `slash`; /tf_static base_footprint -> laser at x = 0.1 m;
    /tf odom -> base_footprint at every stamp of the first topic, x = 0.1 m per second;
    `epoch` (ns) on /log_epoch when given."""
    from rosbags.rosbag1 import Writer
    ts = typestore("ros1")
    T = ts.types
    scans = {"/scan": [1.0, 2.0, 3.0]} if scans is None else scans

    def header(t, frame):
        stamp = T["builtin_interfaces/msg/Time"](sec=int(t), nanosec=round((t - int(t)) * 1e9))
        return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=slash + frame)

    def tf_msg(t, parent, child, x):
        shift = T["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=0.2)
        level = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
        tr = T["geometry_msgs/msg/Transform"](translation=shift, rotation=level)
        tf = T["geometry_msgs/msg/TransformStamped"](header=header(t, parent), child_frame_id=slash + child,
                                                     transform=tr)
        return ts.serialize_ros1(T["tf2_msgs/msg/TFMessage"](transforms=[tf]), "tf2_msgs/msg/TFMessage")

    with Writer(path) as w:
        c = w.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts, latching=1)
        w.write(c, 10**9, tf_msg(1.0, "base_footprint", "laser", 0.1))
        for topic, stamps in scans.items():
            c = w.add_connection(topic, "sensor_msgs/msg/LaserScan", typestore=ts)
            for k, t in enumerate(stamps):
                msg = T["sensor_msgs/msg/LaserScan"](
                    header=header(t, "laser"), angle_min=-1.0, angle_max=1.0, angle_increment=0.5,
                    time_increment=0.0, scan_time=0.1, range_min=0.1, range_max=30.0,
                    ranges=np.full(5, 1.0 + k, np.float32), intensities=np.zeros(0, np.float32))
                w.write(c, (k + 1) * 10**9, ts.serialize_ros1(msg, "sensor_msgs/msg/LaserScan"))
        if epoch is not None:
            c = w.add_connection("/log_epoch", "std_msgs/msg/Int64", typestore=ts, latching=1)
            w.write(c, 10**9, ts.serialize_ros1(T["std_msgs/msg/Int64"](data=epoch), "std_msgs/msg/Int64"))
        if tf_odom:
            c = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=ts)
            for k, t in enumerate(next(iter(scans.values()))):
                w.write(c, (k + 1) * 10**9, tf_msg(t, "odom", "base_footprint", 0.1 * t))
    return path


def _stderr_lines(capsys):
    return capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("slash", ["", "/"])
def test_frames_with_a_leading_slash_keep_odometry_and_mounting(tmp_path, slash):
    log = import_bag(_ros1_bag(tmp_path / "b.bag", slash=slash))
    np.testing.assert_allclose(log.odom_t, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(log.odom_pose[:, 0], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(log.lidar_offset, [0.1, 0.0, 0.0], atol=1e-12)
    assert log.meta["lidar"]["frame"] == "laser"


def test_a_foreign_bag_keeps_its_own_stamps(tmp_path):
    log = import_bag(_ros1_bag(tmp_path / "b.bag", scans={"/scan": [1.7e9 + 0.25, 1.7e9 + 0.5]}))
    assert log.meta["source"]["epoch_ns"] is None
    np.testing.assert_array_equal(log.scan_t, [1.7e9 + 0.25, 1.7e9 + 0.5])


def test_several_scan_topics_take_the_first_and_warn(tmp_path):
    bag = _ros1_bag(tmp_path / "b.bag", scans={"/rear/scan": [1.0, 2.0], "/front/scan": [1.5, 2.5]})
    log = import_bag(bag)
    assert log.meta["source"]["scan_topic"] == "/front/scan"
    [warning] = log.meta["import_warnings"]
    assert "took /front/scan" in warning and "/rear/scan" in warning
    chosen = import_bag(bag, scan_topic="/rear/scan")
    np.testing.assert_allclose(chosen.scan_t, [1.0, 2.0])
    assert chosen.meta["import_warnings"] == []


def test_scan_is_preferred_among_several_but_still_warned(tmp_path):
    log = import_bag(_ros1_bag(tmp_path / "b.bag", scans={"/scan": [1.0, 2.0], "/a/scan": [1.0, 2.0]}))
    assert log.meta["source"]["scan_topic"] == "/scan"
    assert "took /scan, not /a/scan" in log.meta["import_warnings"][0]


def test_cli_topic_choice_and_one_warning_line(tmp_path, capsys):
    bag = _ros1_bag(tmp_path / "b.bag", scans={"/rear/scan": [1.0, 2.0], "/front/scan": [1.5, 2.5]})
    assert sim_main(["import", str(bag), "--out", str(tmp_path / "a.npz")]) == 0
    [line] = _stderr_lines(capsys)
    assert line.startswith(f"warning: {bag}: 2 laser scan topics: took /front/scan, not /rear/scan")
    assert sim_main(["import", str(bag), "--out", str(tmp_path / "b.npz"), "--topic", "/rear/scan"]) == 0
    assert _stderr_lines(capsys) == []


def test_stamps_out_of_order_are_sorted_with_a_count(tmp_path):
    log = import_bag(_ros1_bag(tmp_path / "b.bag", scans={"/scan": [1.0, 3.0, 2.0, 5.0, 4.0, 6.0]}))
    np.testing.assert_array_equal(log.scan_t, [1, 2, 3, 4, 5, 6])
    np.testing.assert_array_equal(log.scan_ranges[:, 0], [1, 3, 2, 5, 4, 6])   # rows follow their stamps
    [warning] = log.meta["import_warnings"]
    assert "/scan 2 of 6" in warning and "/tf 2 of 6" in warning


def test_stamps_in_order_give_no_warning(tmp_path):
    assert import_bag(_ros1_bag(tmp_path / "b.bag")).meta["import_warnings"] == []


def test_import_keeps_an_existing_out_without_force(tmp_path, capsys):
    bag = _ros1_bag(tmp_path / "b.bag")
    out = tmp_path / "back.npz"
    out.write_bytes(b"keep me")
    assert sim_main(["import", str(bag), "--out", str(out)]) == 2
    [line] = _stderr_lines(capsys)
    assert line == f"error: {out}: exists already (--force overwrites it)"
    assert out.read_bytes() == b"keep me"
    assert sim_main(["import", str(bag), "--out", str(out), "--force"]) == 0
    assert out.read_bytes() != b"keep me"


def test_an_unknown_topic_is_one_line_naming_the_bag(tmp_path, capsys):
    bag = _ros1_bag(tmp_path / "b.bag")
    assert sim_main(["import", str(bag), "--out", str(tmp_path / "x.npz"), "--topic", "/nope"]) == 2
    [line] = _stderr_lines(capsys)
    assert line.startswith(f"error: {bag}: no topic /nope (topics: ")


def test_a_recorded_epoch_is_taken_off_and_a_wrong_one_refused(tmp_path):
    log = import_bag(_ros1_bag(tmp_path / "a.bag", scans={"/scan": [1000.5, 1001.5]}, epoch=1000 * 10**9))
    np.testing.assert_array_equal(log.scan_t, [0.5, 1.5])
    with pytest.raises(InputError, match=r"b.bag: /log_epoch: -1 ns is not a time a bag can hold"):
        import_bag(_ros1_bag(tmp_path / "b.bag", epoch=-1))
