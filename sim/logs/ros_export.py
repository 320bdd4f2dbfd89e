"""Sensor logs as ROS bags: ROS 1 (.bag), ROS 2 (sqlite3) and MCAP, with the frames and topics
of a TurtleBot3, so stock TurtleBot3 configurations of ROS SLAMs run on them (`export_bag`;
reading bags back: sim.logs.ros_import).

Topics: /scan sensor_msgs/LaserScan (stamp = first beam, time_increment and scan_time from the
lidar, +inf for no return as REP 117), /odom nav_msgs/Odometry and /tf odom -> base_footprint,
/tf_static base_footprint -> base_link -> base_scan and imu_link at the TurtleBot3 Burger
URDF's heights (latched in ROS 1, transient-local in ROS 2), /imu sensor_msgs/Imu (gravity in
linear_acceleration.z, orientation from the integrated yaw), /ground_truth nav_msgs/Odometry
in frame `map` (never in /tf), /log_epoch std_msgs/Int64.
Stamps are integer nanoseconds: epoch + the log's time, each time rounded once to the nearest
nanosecond (ROS reads stamp 0 as "no time", so a bag starts at a real epoch).
Needs the optional `rosbags` package (`pip install .[ros]`).
"""
from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from worlds.yamlio import InputError
from sim.logs.ros_msgs import EPOCH_TOPIC, LAST_SECOND, NS, typestore
from sim.logs.sensorlog import SensorLog

__all__ = ["FORMATS", "DEFAULT_EPOCH", "export_bag"]

FORMATS = ("ros1", "ros2", "mcap")
GRAVITY = 9.80665
# s: the stamp of the log's time 0 (2023-11-14 22:13:20 UTC), a round real time
DEFAULT_EPOCH = 1_700_000_000
# m: TurtleBot3 Burger URDF (turtlebot3_description): base_joint z, scan_joint z, imu_joint z;
# the lidar's x, y, yaw come from the log, the simulated IMU sits at the robot's centre
BASE_LINK_Z = 0.010
SCAN_Z = 0.172
IMU_Z = 0.068


def _to_ns(t: np.ndarray) -> np.ndarray:
    """(N,) times in seconds -> (N,) int64 nanoseconds, each the nearest to its time.

    The whole seconds are split off first (exact for a float), so the rounding acts on the
    fraction alone and a time of 2.9999999999996 s becomes 3_000_000_000 ns.
    """
    t = np.asarray(t, dtype=np.float64)
    sec = np.floor(t)
    return sec.astype(np.int64) * NS + np.round((t - sec) * 1e9).astype(np.int64)


def _stamp(ts, ns: int):
    sec, nanosec = divmod(int(ns), NS)
    return ts.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def _header(ts, fmt: str, ns: int, frame: str, seq: int = 0):
    H = ts.types["std_msgs/msg/Header"]
    if fmt == "ros1":
        return H(seq=seq, stamp=_stamp(ts, ns), frame_id=frame)
    return H(stamp=_stamp(ts, ns), frame_id=frame)


def _quat(ts, yaw: float):
    return ts.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _vec(ts, x=0.0, y=0.0, z=0.0):
    return ts.types["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=float(z))


def _transform(ts, fmt, ns, parent, child, x, y, yaw, z=0.0):
    T = ts.types
    tr = T["geometry_msgs/msg/Transform"](translation=_vec(ts, x, y, z), rotation=_quat(ts, yaw))
    return T["geometry_msgs/msg/TransformStamped"](header=_header(ts, fmt, ns, parent), child_frame_id=child,
                                                   transform=tr)


def _odometry(ts, fmt, ns, frame, child, pose, v=0.0, w=0.0, seq=0):
    T = ts.types
    point = T["geometry_msgs/msg/Point"](x=float(pose[0]), y=float(pose[1]), z=0.0)
    p = T["geometry_msgs/msg/Pose"](position=point, orientation=_quat(ts, float(pose[2])))
    tw = T["geometry_msgs/msg/Twist"](linear=_vec(ts, v), angular=_vec(ts, 0.0, 0.0, w))
    zeros = np.zeros(36, dtype=np.float64)
    return T["nav_msgs/msg/Odometry"](
        header=_header(ts, fmt, ns, frame, seq), child_frame_id=child,
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=p, covariance=zeros),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=tw, covariance=zeros))


def _latched_qos():
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    never = QosTime(sec=0, nsec=0)
    return [Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL,
                never, never, QosLiveliness.AUTOMATIC, never, False)]


class _BagWriter:
    """One bag being written: connections by topic, messages serialized for its format."""

    def __init__(self, fmt: str, path: Path, ts):
        self.fmt, self.ts = fmt, ts
        if fmt == "ros1":
            from rosbags.rosbag1 import Writer
            self.writer = Writer(path)
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer
            plugin = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
            self.writer = Writer(path, version=8, storage_plugin=plugin)
        self.writer.open()
        self.conns: dict[str, object] = {}

    def connect(self, topic: str, msgtype: str, latched: bool = False) -> None:
        if self.fmt == "ros1":
            self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.ts,
                                                           latching=1 if latched else None)
        else:
            qos = _latched_qos() if latched else ()
            self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.ts,
                                                           offered_qos_profiles=qos)

    def write(self, topic: str, ns: int, msg) -> None:
        """Write `msg` on `topic` at bag time `ns` (integer nanoseconds, the header's stamp)."""
        data = (self.ts.serialize_ros1(msg, msg.__msgtype__) if self.fmt == "ros1"
                else self.ts.serialize_cdr(msg, msg.__msgtype__))
        self.writer.write(self.conns[topic], int(ns), data)

    def close(self) -> None:
        self.writer.close()


def _log_stamps(log: SensorLog, epoch: int, fmt: str) -> dict[str, list[int]]:
    """Stamps (int ns: epoch s + each time) of each time stream of `log`, by array name;
    InputError unless every stamp lies after 0 and within the format's time type."""
    if not log.n_scans:
        raise InputError("the log has no scans (a bag needs /scan)")
    names = [n for n in ("scan_t", "odom_t", "imu_t", "gt_t") if len(getattr(log, n))]
    first = min(float(getattr(log, n)[0]) for n in names)    # a log's times increase
    last = max(float(getattr(log, n)[-1]) for n in names)
    end = LAST_SECOND[fmt] + 1
    problem = (f"--epoch: {epoch} s puts the log's times {first:.12g}..{last:.12g} s outside "
               f"{'ROS 1' if fmt == 'ros1' else 'ROS 2'} time (stamp = epoch + time must lie "
               f"after 0 and before {end} s)")
    if epoch >= end or not -end < first <= last < end:   # before the int64 nanoseconds
        raise InputError(problem)
    stamps = {n: (_to_ns(getattr(log, n)) + epoch * NS).tolist() for n in names}
    if min(s[0] for s in stamps.values()) <= 0 or max(s[-1] for s in stamps.values()) >= end * NS:
        raise InputError(problem)
    return stamps


def _write_statics(bag: _BagWriter, log: SensorLog, ns: int, epoch_ns: int) -> None:
    """/tf_static (the Burger's heights, the log's lidar mounting) and /log_epoch, at `ns`."""
    ts, fmt = bag.ts, bag.fmt
    off = log.lidar_offset
    bag.connect("/tf_static", "tf2_msgs/msg/TFMessage", latched=True)
    statics = [_transform(ts, fmt, ns, "base_footprint", "base_link", 0.0, 0.0, 0.0, BASE_LINK_Z),
               _transform(ts, fmt, ns, "base_link", "base_scan", off[0], off[1], off[2], SCAN_Z),
               _transform(ts, fmt, ns, "base_link", "imu_link", 0.0, 0.0, 0.0, IMU_Z)]
    bag.write("/tf_static", ns, ts.types["tf2_msgs/msg/TFMessage"](transforms=statics))
    bag.connect(EPOCH_TOPIC, "std_msgs/msg/Int64", latched=True)
    bag.write(EPOCH_TOPIC, ns, ts.types["std_msgs/msg/Int64"](data=epoch_ns))


def _write_scans(bag: _BagWriter, log: SensorLog, stamps: list[int]) -> None:
    """/scan, one LaserScan per scan of `log`."""
    ts, fmt = bag.ts, bag.fmt
    lidar = log.meta.get("lidar", {})
    angles = np.asarray(log.scan_angles, dtype=np.float64)
    inc = float(np.median(np.diff(angles))) if len(angles) > 1 else 0.0
    scan_time = float(lidar.get("scan_time", 1.0 / float(lidar.get("rate", 5.0))))
    bag.connect("/scan", "sensor_msgs/msg/LaserScan")
    for i, ns in enumerate(stamps):
        r = np.asarray(log.scan_ranges[i], dtype=np.float32)
        msg = ts.types["sensor_msgs/msg/LaserScan"](
            header=_header(ts, fmt, ns, "base_scan", i), angle_min=float(angles[0]),
            angle_max=float(angles[0] + inc * (len(angles) - 1)), angle_increment=inc,
            time_increment=float(lidar.get("time_increment", 0.0)), scan_time=scan_time,
            range_min=float(log.range_min), range_max=float(log.range_max), ranges=r,
            intensities=np.zeros(0, dtype=np.float32))
        bag.write("/scan", ns, msg)


def _write_odometry(bag: _BagWriter, log: SensorLog, stamps: list[int]) -> None:
    """/odom and /tf odom -> base_footprint at every odometry sample."""
    ts, fmt = bag.ts, bag.fmt
    bag.connect("/odom", "nav_msgs/msg/Odometry")
    bag.connect("/tf", "tf2_msgs/msg/TFMessage")
    for i, ns in enumerate(stamps):
        p, tw = log.odom_pose[i], log.odom_twist[i]
        bag.write("/odom", ns, _odometry(ts, fmt, ns, "odom", "base_footprint", p, tw[0], tw[1], i))
        tf = _transform(ts, fmt, ns, "odom", "base_footprint", p[0], p[1], p[2])
        bag.write("/tf", ns, ts.types["tf2_msgs/msg/TFMessage"](transforms=[tf]))


def _write_imu(bag: _BagWriter, log: SensorLog, stamps: list[int]) -> None:
    """/imu: yaw rate, planar acceleration with gravity on z, orientation from the yaw."""
    ts, fmt = bag.ts, bag.fmt
    bag.connect("/imu", "sensor_msgs/msg/Imu")
    cov = np.zeros(9, dtype=np.float64)
    for i, ns in enumerate(stamps):
        msg = ts.types["sensor_msgs/msg/Imu"](
            header=_header(ts, fmt, ns, "imu_link", i),
            orientation=_quat(ts, float(log.imu_yaw[i])),
            orientation_covariance=cov, angular_velocity=_vec(ts, 0.0, 0.0, log.imu_gyro[i]),
            angular_velocity_covariance=cov,
            linear_acceleration=_vec(ts, log.imu_accel[i, 0], log.imu_accel[i, 1], GRAVITY),
            linear_acceleration_covariance=cov)
        bag.write("/imu", ns, msg)


def _write_messages(bag: _BagWriter, log: SensorLog, stamps: dict[str, list[int]],
                    epoch_ns: int) -> None:
    """Every topic of the module docstring, with the stamps of `_log_stamps` (by array name,
    streams the log lacks left out)."""
    first = min(s[0] for s in stamps.values() if s)
    _write_statics(bag, log, first, epoch_ns)
    _write_scans(bag, log, stamps["scan_t"])
    if log.has_odometry:
        _write_odometry(bag, log, stamps["odom_t"])
    if log.has_imu:
        _write_imu(bag, log, stamps["imu_t"])
    if log.has_ground_truth:
        bag.connect("/ground_truth", "nav_msgs/msg/Odometry")
        for i, ns in enumerate(stamps["gt_t"]):
            bag.write("/ground_truth", ns, _odometry(bag.ts, bag.fmt, ns, "map", "base_footprint",
                                                     log.gt_pose[i], seq=i))


def export_bag(log: SensorLog, out: str | Path, fmt: str, epoch: int = DEFAULT_EPOCH) -> Path:
    """Write `log` as a ROS 1 bag (`out` a .bag file), a ROS 2 bag or an MCAP bag (`out` a
    folder, as ros2 bag record makes); written beside and renamed into place, so a failure
    leaves nothing half-written. Returns the path written.

    epoch: whole seconds added to the log's times (stamp = epoch + time, in integer ns), kept
    on /log_epoch; every stamp must fall after 0 and within the format's time type.
    """
    if fmt not in FORMATS:
        raise InputError(f"--format: {fmt!r} is not one of {', '.join(FORMATS)}")
    if not isinstance(epoch, int) or isinstance(epoch, bool) or epoch < 0:
        raise InputError(f"--epoch: expected a whole number of seconds >= 0, got {epoch!r}")
    out = Path(out)
    if out.exists():
        raise InputError(f"{out}: exists already (a bag is never overwritten)")
    stamps = _log_stamps(log, epoch, fmt)
    ts = typestore(fmt)
    # written inside a hidden folder beside `out` and moved into place: a ROS 2 bag names its
    # storage file after its folder, so the folder gets its final name from the start
    stage = out.with_name(f".{out.name}.part")
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir(parents=True)
    try:
        bag = _BagWriter(fmt, stage / out.name, ts)
        try:
            _write_messages(bag, log, stamps, epoch * NS)
        finally:
            bag.close()
        (stage / out.name).rename(out)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return out
