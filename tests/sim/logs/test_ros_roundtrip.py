"""Sensor logs as ROS bags (sim.logs.ros_export, sim.logs.ros_import): round trips through
ROS 1, ROS 2 and MCAP, the bags read by independent readers, and one-line errors on bags that
cannot be used."""
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from sim.__main__ import main as sim_main  # noqa: E402
from sim.logs import export_bag, import_bag, write_log  # noqa: E402
from sim.logs.ros_msgs import typestore  # noqa: E402
from tests.slam.synthlog import box_room_segments, make_log  # noqa: E402
from worlds.yamlio import InputError  # noqa: E402

ARRAYS = ("scan_t", "scan_ranges", "scan_angles", "odom_t", "odom_pose", "odom_twist", "imu_t",
          "imu_gyro", "imu_accel", "imu_yaw", "gt_t", "gt_pose")
SYSTEM_PYTHON = "/usr/bin/python3"


@pytest.fixture(scope="module")
def log():
    return make_log(box_room_segments(), np.array([[1.0, 1.0], [2.5, 1.0], [2.5, 2.5]]), seed=8)


def _same(a, b):
    for name in ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape, name
        assert np.array_equal(np.isinf(x), np.isinf(y)), name
        fin = np.isfinite(x)
        # ranges travel as float32 (sensor_msgs/LaserScan), times as integer nanoseconds
        np.testing.assert_allclose(y[fin], x[fin], rtol=1e-6, atol=1e-6, err_msg=name)


@pytest.mark.parametrize("fmt", ["ros1", "ros2", "mcap"])
def test_round_trip_keeps_every_array(log, tmp_path, fmt):
    out = export_bag(log, tmp_path / ("b.bag" if fmt == "ros1" else "b"), fmt)
    back = import_bag(out)
    _same(log, back)
    np.testing.assert_allclose(back.lidar_offset, log.lidar_offset, atol=1e-12)
    assert back.meta["lidar"]["time_increment"] == pytest.approx(log.meta["lidar"]["time_increment"])
    assert not list(tmp_path.glob(".*part*"))


def test_mcap_is_decoded_by_the_mcap_libraries(log, tmp_path):
    reader_mod = pytest.importorskip("mcap.reader")
    decoder = pytest.importorskip("mcap_ros2.decoder")
    out = export_bag(log, tmp_path / "b", "mcap")
    counts, first = {}, {}
    with open(next(out.glob("*.mcap")), "rb") as fh:
        reader = reader_mod.make_reader(fh, decoder_factories=[decoder.DecoderFactory()])
        for schema, channel, message, ros_msg in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            first.setdefault(channel.topic, (schema.name, channel, ros_msg))
    assert counts["/scan"] == log.n_scans and counts["/odom"] == len(log.odom_t)
    assert counts["/imu"] == len(log.imu_t) and counts["/ground_truth"] == len(log.gt_t)
    name, _, scan = first["/scan"]
    assert name == "sensor_msgs/msg/LaserScan" and scan.header.frame_id == "base_scan"
    assert len(scan.ranges) == len(log.scan_angles)
    assert scan.time_increment == pytest.approx(log.meta["lidar"]["time_increment"], rel=1e-6)
    assert first["/imu"][2].linear_acceleration.z == pytest.approx(9.80665)
    _, static, tf = first["/tf_static"]
    qos = static.metadata["offered_qos_profiles"]   # rosbag2's YAML; durability 1 = transient local
    assert "durability: 1" in qos and "depth: 1" in qos
    assert {(t.header.frame_id, t.child_frame_id) for t in tf.transforms} == {
        ("base_footprint", "base_link"), ("base_link", "base_scan"), ("base_link", "imu_link")}
    assert all(t.child_frame_id == "base_footprint" and t.header.frame_id == "odom"
               for t in first["/tf"][2].transforms)   # ground truth never in /tf


@pytest.mark.skipif(not Path(SYSTEM_PYTHON).exists() or subprocess.run(
    [SYSTEM_PYTHON, "-c", "import rosbag"], capture_output=True).returncode != 0,
    reason="needs Debian's python3-rosbag")
def test_ros1_bag_is_read_by_rosbag(log, tmp_path):
    out = export_bag(log, tmp_path / "b.bag", "ros1")
    code = ("import rosbag, sys\n"
            "b = rosbag.Bag(sys.argv[1])\n"
            "i = b.get_type_and_topic_info().topics\n"
            "print(i['/scan'].msg_type, i['/scan'].message_count, i['/odom'].message_count)\n"
            "m = next(b.read_messages(topics=['/scan']))[1]\n"
            "print(m.header.frame_id, len(m.ranges), round(m.time_increment, 9))\n"
            "c = [c for c in b._connections.values() if c.topic == '/tf_static'][0]\n"
            "print(c.header.get('latching'))\n")
    res = subprocess.run([SYSTEM_PYTHON, "-c", code, str(out)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.split("\n")
    assert lines[0] == f"sensor_msgs/LaserScan {log.n_scans} {len(log.odom_t)}"
    assert lines[1] == f"base_scan {len(log.scan_angles)} {round(log.meta['lidar']['time_increment'], 9)}"
    assert lines[2] == "b'1'"


def _ros1_bag(path, scans=(), odom=False, static_roll=0.0, multi=False):
    """A hand-made ROS 1 bag: LaserScans (or MultiEchoLaserScans) of the given beam counts."""
    from rosbags.rosbag1 import Writer
    ts = typestore("ros1")
    T = ts.types

    def header(t, frame):
        return T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=int(t), nanosec=0),
                                        frame_id=frame)
    with Writer(path) as w:
        if static_roll is not None:
            c = w.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts, latching=1)
            q = T["geometry_msgs/msg/Quaternion"](x=math.sin(static_roll / 2), y=0.0, z=0.0, w=math.cos(static_roll / 2))
            tr = T["geometry_msgs/msg/Transform"](translation=T["geometry_msgs/msg/Vector3"](x=0.1, y=0.0, z=0.2),
                                                  rotation=q)
            tf = T["geometry_msgs/msg/TransformStamped"](header=header(1, "base_footprint"),
                                                         child_frame_id="laser", transform=tr)
            w.write(c, 10**9, ts.serialize_ros1(T["tf2_msgs/msg/TFMessage"](transforms=[tf]), "tf2_msgs/msg/TFMessage"))
        if scans:
            kind = "sensor_msgs/msg/MultiEchoLaserScan" if multi else "sensor_msgs/msg/LaserScan"
            c = w.add_connection("/scan", kind, typestore=ts)
            for k, n in enumerate(scans):
                t = 1 + k
                r = np.linspace(1.0, 2.0, n).astype(np.float32)
                r[0] = np.nan
                if multi:
                    ranges = [T["sensor_msgs/msg/LaserEcho"](echoes=np.array([v, v + 1], np.float32)) for v in r]
                    msg = T[kind](header=header(t, "laser"), angle_min=-1.0, angle_max=1.0,
                                  angle_increment=2.0 / (n - 1), time_increment=0.0, scan_time=0.1,
                                  range_min=0.1, range_max=30.0, ranges=ranges, intensities=[])
                    w.write(c, t * 10**9, ts.serialize_ros1(msg, kind))
                    continue
                msg = T[kind](header=header(t, "laser"), angle_min=-1.0, angle_max=1.0,
                              angle_increment=2.0 / (n - 1), time_increment=0.0, scan_time=0.1,
                              range_min=0.1, range_max=30.0, ranges=r, intensities=np.zeros(0, np.float32))
                w.write(c, t * 10**9, ts.serialize_ros1(msg, kind))
        if odom:
            c = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
    return path


def test_a_bag_without_a_scan_topic_lists_its_topics(tmp_path):
    bag = _ros1_bag(tmp_path / "b.bag", scans=(), odom=True)
    with pytest.raises(InputError, match=r"b.bag: no laser scan topic .*topics: /odom \(nav_msgs/msg/Odometry\), "
                                         r"/tf_static"):
        import_bag(bag)


def test_a_topic_of_the_wrong_type_is_refused(tmp_path):
    bag = _ros1_bag(tmp_path / "b.bag", scans=(5, 5), odom=True)
    with pytest.raises(InputError, match=r"/odom: message type nav_msgs/msg/Odometry is not"):
        import_bag(bag, scan_topic="/odom")


def test_a_changing_beam_count_names_the_topic_and_time(tmp_path):
    bag = _ros1_bag(tmp_path / "b.bag", scans=(5, 5, 7))
    with pytest.raises(InputError, match=r"/scan: the scan at 3.000 s has 7 beams, the first had 5"):
        import_bag(bag)


def test_a_truncated_bag_is_one_line(log, tmp_path):
    out = export_bag(log, tmp_path / "b.bag", "ros1")
    cut = tmp_path / "cut.bag"
    cut.write_bytes(out.read_bytes()[:len(out.read_bytes()) // 3])
    with pytest.raises(InputError, match=r"cut.bag: not a readable ROS bag") as err:
        import_bag(cut)
    assert "\n" not in str(err.value)


def test_rep117_values_upside_down_mount_and_multi_echo(tmp_path):
    plain = import_bag(_ros1_bag(tmp_path / "a.bag", scans=(5, 5), static_roll=0.0))
    assert np.isinf(plain.scan_ranges[:, 0]).all()          # NaN: no return
    np.testing.assert_allclose(plain.scan_angles, [-1, -0.5, 0, 0.5, 1])
    np.testing.assert_allclose(plain.lidar_offset, [0.1, 0.0, 0.0], atol=1e-12)
    flipped = import_bag(_ros1_bag(tmp_path / "b.bag", scans=(5, 5), static_roll=math.pi))
    assert flipped.meta["lidar"]["upside_down"]
    np.testing.assert_allclose(flipped.scan_angles, [1, 0.5, 0, -0.5, -1])
    multi = import_bag(_ros1_bag(tmp_path / "c.bag", scans=(5, 5), multi=True))
    np.testing.assert_allclose(multi.scan_ranges[:, 1:], plain.scan_ranges[:, 1:])   # first echo


def test_cli_export_and_import(log, tmp_path, capsys):
    write_log(log, tmp_path / "log.npz")
    assert sim_main(["export", str(tmp_path / "log.npz"), "--format", "mcap", "--out", str(tmp_path / "bag")]) == 0
    assert sim_main(["import", str(tmp_path / "bag"), "--out", str(tmp_path / "back.npz")]) == 0
    capsys.readouterr()
    assert sim_main(["export", str(tmp_path / "log.npz"), "--format", "ros1", "--out", str(tmp_path / "bag")]) == 2
    assert "exists already" in capsys.readouterr().err
    shutil.rmtree(tmp_path / "bag")
