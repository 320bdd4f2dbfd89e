"""Sensor logs as ROS bags, both ways: ROS 1 (.bag), ROS 2 (sqlite3) and MCAP, with the frames
and topics of a TurtleBot3, so stock TurtleBot3 configurations of ROS SLAMs run on them.

Export (`export_bag`): /scan sensor_msgs/LaserScan (stamp = first beam, time_increment and
scan_time from the lidar, +inf for no return as REP 117), /odom nav_msgs/Odometry and /tf
odom -> base_footprint, /tf_static base_footprint -> base_link -> base_scan and imu_link
(latched in ROS 1, transient-local in ROS 2), /imu sensor_msgs/Imu (gravity in
linear_acceleration.z, orientation from the integrated yaw), /ground_truth nav_msgs/Odometry in
frame `map` (never in /tf).
Import (`import_bag`): LaserScan or MultiEchoLaserScan (first echo), NaN and +-inf as no
return (REP 117; finite readings outside [range_min, range_max] are kept, and the SLAMs'
preprocessing drops them), the lidar's mounting from /tf_static (an
upside-down scanner flips the beam order), odometry from /odom (else /tf odom ->
base_footprint), the IMU's yaw rate and yaw, header stamps. Needs the optional `rosbags`
package (`pip install .[ros]`).
"""
from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from worlds.yamlio import InputError
from sim.log import SensorLog, value_problem

__all__ = ["FORMATS", "export_bag", "import_bag"]

FORMATS = ("ros1", "ros2", "mcap")
GRAVITY = 9.80665
_TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"


def _rosbags():
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise InputError("ROS bags need the optional package rosbags: pip install .[ros]") from None
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    return Stores, get_types_from_msg, get_typestore


def _typestore(fmt: str):
    stores, get_types_from_msg, get_typestore = _rosbags()
    ts = get_typestore(stores.ROS1_NOETIC if fmt == "ros1" else stores.ROS2_HUMBLE)
    if "tf2_msgs/msg/TFMessage" not in ts.types:
        ts.register(get_types_from_msg(_TF_MSG, "tf2_msgs/msg/TFMessage"))
    return ts


def _stamp(ts, t: float):
    sec = int(math.floor(t))
    nanosec = int(round((t - sec) * 1e9)) % 1_000_000_000
    return ts.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def _header(ts, fmt: str, t: float, frame: str, seq: int = 0):
    H = ts.types["std_msgs/msg/Header"]
    if fmt == "ros1":
        return H(seq=seq, stamp=_stamp(ts, t), frame_id=frame)
    return H(stamp=_stamp(ts, t), frame_id=frame)


def _quat(ts, yaw: float):
    return ts.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _vec(ts, x=0.0, y=0.0, z=0.0):
    return ts.types["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=float(z))


def _transform(ts, fmt, t, parent, child, x, y, yaw):
    T = ts.types
    tr = T["geometry_msgs/msg/Transform"](translation=_vec(ts, x, y), rotation=_quat(ts, yaw))
    return T["geometry_msgs/msg/TransformStamped"](header=_header(ts, fmt, t, parent), child_frame_id=child,
                                                   transform=tr)


def _odometry(ts, fmt, t, frame, child, pose, v=0.0, w=0.0, seq=0):
    T = ts.types
    point = T["geometry_msgs/msg/Point"](x=float(pose[0]), y=float(pose[1]), z=0.0)
    p = T["geometry_msgs/msg/Pose"](position=point, orientation=_quat(ts, float(pose[2])))
    tw = T["geometry_msgs/msg/Twist"](linear=_vec(ts, v), angular=_vec(ts, 0.0, 0.0, w))
    zeros = np.zeros(36, dtype=np.float64)
    return T["nav_msgs/msg/Odometry"](
        header=_header(ts, fmt, t, frame, seq), child_frame_id=child,
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

    def write(self, topic: str, t: float, msg) -> None:
        data = (self.ts.serialize_ros1(msg, msg.__msgtype__) if self.fmt == "ros1"
                else self.ts.serialize_cdr(msg, msg.__msgtype__))
        self.writer.write(self.conns[topic], int(round(t * 1e9)), data)

    def close(self) -> None:
        self.writer.close()


def _write_messages(bag: _BagWriter, log: SensorLog) -> None:
    ts, fmt = bag.ts, bag.fmt
    T = ts.types
    lidar = log.meta.get("lidar", {})
    angles = np.asarray(log.scan_angles, dtype=np.float64)
    inc = float(np.median(np.diff(angles))) if len(angles) > 1 else 0.0
    scan_time = float(lidar.get("scan_time", 1.0 / float(lidar.get("rate", 5.0))))
    bag.connect("/tf_static", "tf2_msgs/msg/TFMessage", latched=True)
    bag.connect("/scan", "sensor_msgs/msg/LaserScan")
    off = log.lidar_offset
    t0 = float(min(a[0] for a in (log.scan_t, log.odom_t, log.imu_t, log.gt_t) if len(a)))
    statics = [_transform(ts, fmt, t0, "base_footprint", "base_link", 0.0, 0.0, 0.0),
               _transform(ts, fmt, t0, "base_link", "base_scan", off[0], off[1], off[2]),
               _transform(ts, fmt, t0, "base_link", "imu_link", 0.0, 0.0, 0.0)]
    bag.write("/tf_static", t0, T["tf2_msgs/msg/TFMessage"](transforms=statics))
    for i, t in enumerate(log.scan_t):
        r = np.asarray(log.scan_ranges[i], dtype=np.float32)
        msg = T["sensor_msgs/msg/LaserScan"](
            header=_header(ts, fmt, float(t), "base_scan", i), angle_min=float(angles[0]),
            angle_max=float(angles[0] + inc * (len(angles) - 1)), angle_increment=inc,
            time_increment=float(lidar.get("time_increment", 0.0)), scan_time=scan_time,
            range_min=float(log.range_min), range_max=float(log.range_max), ranges=r,
            intensities=np.zeros(0, dtype=np.float32))
        bag.write("/scan", float(t), msg)
    if log.has_odometry:
        bag.connect("/odom", "nav_msgs/msg/Odometry")
        bag.connect("/tf", "tf2_msgs/msg/TFMessage")
        for i, t in enumerate(log.odom_t):
            p, tw = log.odom_pose[i], log.odom_twist[i]
            odom = _odometry(ts, fmt, float(t), "odom", "base_footprint", p, tw[0], tw[1], i)
            bag.write("/odom", float(t), odom)
            tf = _transform(ts, fmt, float(t), "odom", "base_footprint", p[0], p[1], p[2])
            bag.write("/tf", float(t), T["tf2_msgs/msg/TFMessage"](transforms=[tf]))
    if log.has_imu:
        bag.connect("/imu", "sensor_msgs/msg/Imu")
        cov = np.zeros(9, dtype=np.float64)
        for i, t in enumerate(log.imu_t):
            msg = T["sensor_msgs/msg/Imu"](
                header=_header(ts, fmt, float(t), "imu_link", i),
                orientation=_quat(ts, float(log.imu_yaw[i])),
                orientation_covariance=cov, angular_velocity=_vec(ts, 0.0, 0.0, log.imu_gyro[i]),
                angular_velocity_covariance=cov,
                linear_acceleration=_vec(ts, log.imu_accel[i, 0], log.imu_accel[i, 1], GRAVITY),
                linear_acceleration_covariance=cov)
            bag.write("/imu", float(t), msg)
    if log.has_ground_truth:
        bag.connect("/ground_truth", "nav_msgs/msg/Odometry")
        for i, t in enumerate(log.gt_t):
            bag.write("/ground_truth", float(t), _odometry(ts, fmt, float(t), "map", "base_footprint",
                                                           log.gt_pose[i], seq=i))


def export_bag(log: SensorLog, out: str | Path, fmt: str) -> Path:
    """Write `log` as a ROS 1 bag (`out` a .bag file), a ROS 2 bag or an MCAP bag (`out` a
    folder, as ros2 bag record makes); written beside and renamed into place, so a failure
    leaves nothing half-written. Returns the path written."""
    if fmt not in FORMATS:
        raise InputError(f"--format: {fmt!r} is not one of {', '.join(FORMATS)}")
    out = Path(out)
    if out.exists():
        raise InputError(f"{out}: exists already (a bag is never overwritten)")
    ts = _typestore(fmt)
    # written inside a hidden folder beside `out` and moved into place: a ROS 2 bag names its
    # storage file after its folder, so the folder gets its final name from the start
    stage = out.with_name(f".{out.name}.part")
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir(parents=True)
    try:
        bag = _BagWriter(fmt, stage / out.name, ts)
        try:
            _write_messages(bag, log)
        finally:
            bag.close()
        (stage / out.name).rename(out)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return out


# --- import ---------------------------------------------------------------------------------

_SCAN_TYPES = ("sensor_msgs/msg/LaserScan", "sensor_msgs/msg/MultiEchoLaserScan")


def _t(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def _yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _planar(tr) -> tuple[float, float, float, bool]:
    """(x, y, yaw, upside_down) of a geometry_msgs/Transform seen from above."""
    q = tr.rotation
    # the yaw is the rotated x axis's; the rotated z axis pointing down, an upside-down mount
    return tr.translation.x, tr.translation.y, _yaw(q), 1 - 2 * (q.x * q.x + q.y * q.y) < 0


def _pick(topics: dict, given: str | None, types: tuple, prefer: str, what: str, path: Path,
          required: bool) -> str | None:
    """The topic to read: `given` (checked), else `prefer` if it has the type, else the only
    topic of the type; None when there is none and it is not required."""
    listing = ", ".join(f"{t} ({m})" for t, m in sorted(topics.items())) or "none"
    if given is not None:
        if given not in topics:
            raise InputError(f"{path}: no topic {given} (topics: {listing})")
        if topics[given] not in types:
            raise InputError(f"{path}: {given}: message type {topics[given]} is not {' or '.join(types)}")
        return given
    if topics.get(prefer) in types:
        return prefer
    found = [t for t, m in sorted(topics.items()) if m in types]
    if not found:
        if required:
            raise InputError(f"{path}: no {what} topic ({' or '.join(types)}; topics: {listing})")
        return None
    return found[0]


def _scan_frame_offset(static: dict, frame: str) -> tuple[np.ndarray, bool]:
    """(x, y, yaw) of `frame` in base_footprint (else base_link) from /tf_static, and whether
    the scanner is mounted upside down; zeros when /tf_static does not reach it."""
    pose, flip, f = np.zeros(3), False, frame
    seen = set()
    while f in static and f not in seen and f not in ("base_footprint",):
        seen.add(f)
        parent, x, y, yaw, down = static[f]
        c, s = math.cos(yaw), math.sin(yaw)
        pose = np.array([x + c * pose[0] - s * pose[1], y + s * pose[0] + c * pose[1], yaw + pose[2]])
        flip ^= down
        f = parent
    return pose, flip


def import_bag(path: str | Path, scan_topic: str | None = None, odom_topic: str | None = None,
               imu_topic: str | None = None) -> SensorLog:
    """A SensorLog from a ROS 1 bag, a ROS 2 bag folder or an MCAP bag (see the module
    docstring); InputError naming the bag (and topic) on anything it cannot use."""
    _rosbags()
    from rosbags.highlevel import AnyReader
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: file not found")
    try:
        with AnyReader([p]) as reader:
            return _read(reader, p, scan_topic, odom_topic, imu_topic)
    except InputError:
        raise
    except Exception as err:   # a damaged or foreign file: whatever the bag readers raise
        reason = " ".join(str(err).split()) or type(err).__name__
        raise InputError(f"{p}: not a readable ROS bag: {reason}") from None


def _messages(reader, topic: str):
    conns = [c for c in reader.connections if c.topic == topic]
    for conn, _, raw in reader.messages(connections=conns):
        yield reader.deserialize(raw, conn.msgtype)


def _read(reader, p: Path, scan_topic, odom_topic, imu_topic) -> SensorLog:
    topics = {c.topic: c.msgtype for c in reader.connections}
    scan_topic = _pick(topics, scan_topic, _SCAN_TYPES, "/scan", "laser scan", p, True)
    odom_topic = _pick(topics, odom_topic, ("nav_msgs/msg/Odometry",), "/odom", "odometry", p, False)
    if odom_topic == "/ground_truth":
        odom_topic = None
    imu_topic = _pick(topics, imu_topic, ("sensor_msgs/msg/Imu",), "/imu", "IMU", p, False)
    static = {}   # child frame -> (parent, x, y, yaw, upside down)
    if topics.get("/tf_static") == "tf2_msgs/msg/TFMessage":
        for msg in _messages(reader, "/tf_static"):
            for tf in msg.transforms:
                static[tf.child_frame_id] = (tf.header.frame_id, *_planar(tf.transform))
    scans, frame, geometry = [], None, None
    multi = topics[scan_topic].endswith("MultiEchoLaserScan")
    for msg in _messages(reader, scan_topic):
        t = _t(msg.header.stamp)
        ranges = (np.array([e.echoes[0] if len(e.echoes) else np.inf for e in msg.ranges])
                  if multi else np.asarray(msg.ranges, dtype=np.float64))
        if geometry is None:
            geometry = (len(ranges), msg.angle_min, msg.angle_increment)
            frame = msg.header.frame_id
        elif len(ranges) != geometry[0]:
            raise InputError(f"{p}: {scan_topic}: the scan at {t:.3f} s has {len(ranges)} beams, "
                             f"the first had {geometry[0]}")
        # REP 117: NaN (no measurement), -inf (too close) and +inf (nothing in range) are all no
        # return; finite readings outside [range_min, range_max] stay as read, for the SLAMs'
        # preprocessing drops them (and a round trip keeps the log as it was)
        bad = ~np.isfinite(ranges) | (ranges < 0)
        scans.append((t, np.where(bad, np.inf, ranges), msg))
    if not scans:
        raise InputError(f"{p}: {scan_topic}: no messages")
    scans.sort(key=lambda s: s[0])
    n, a0, inc = geometry
    angles = a0 + inc * np.arange(n)
    offset, flip = _scan_frame_offset(static, frame)
    if flip:
        angles = -angles
    first = scans[0][2]
    lidar = {"beams": int(n), "range_min": float(first.range_min),
             "range_max": float(max(s[2].range_max for s in scans)), "offset": [float(v) for v in offset],
             "time_increment": float(abs(first.time_increment)), "scan_time": float(first.scan_time),
             "frame": frame, "upside_down": bool(flip)}
    arrays = {"scan_t": np.array([s[0] for s in scans]), "scan_ranges": np.vstack([s[1] for s in scans]),
              "scan_angles": angles}
    arrays.update(_odometry_arrays(reader, topics, odom_topic, p))
    if imu_topic:
        arrays.update(_imu_arrays(reader, imu_topic))
    if topics.get("/ground_truth") == "nav_msgs/msg/Odometry":
        t, pose, _ = _odom_rows(_messages(reader, "/ground_truth"))
        arrays.update(gt_t=t, gt_pose=pose)
    gt = arrays.get("gt_pose", np.zeros((0, 3)))
    meta = {"lidar": lidar, "source": {"bag": str(p), "scan_topic": scan_topic,
                                        "odom_topic": odom_topic, "imu_topic": imu_topic},
            "start_pose": [float(v) for v in gt[0]] if len(gt) else None}
    log = SensorLog(**arrays, meta=meta)
    problem = value_problem(log)
    if problem:
        raise InputError(f"{p}: {problem}")
    return log


def _odom_rows(msgs):
    rows = sorted(((_t(m.header.stamp), m.pose.pose.position.x, m.pose.pose.position.y,
                    _yaw(m.pose.pose.orientation), m.twist.twist.linear.x, m.twist.twist.angular.z)
                   for m in msgs), key=lambda r: r[0])
    a = np.array(rows, dtype=np.float64).reshape(-1, 6)
    return a[:, 0], a[:, 1:4], a[:, 4:6]


def _odometry_arrays(reader, topics: dict, odom_topic: str | None, p: Path) -> dict:
    if odom_topic:
        t, pose, twist = _odom_rows(_messages(reader, odom_topic))
        return {"odom_t": t, "odom_pose": pose, "odom_twist": twist}
    if topics.get("/tf") != "tf2_msgs/msg/TFMessage":
        return {}
    rows = []
    for msg in _messages(reader, "/tf"):
        for tf in msg.transforms:
            if tf.header.frame_id == "odom" and tf.child_frame_id in ("base_footprint", "base_link"):
                x, y, yaw, _ = _planar(tf.transform)
                rows.append((_t(tf.header.stamp), x, y, yaw))
    if not rows:
        return {}
    a = np.array(sorted(rows), dtype=np.float64)
    return {"odom_t": a[:, 0], "odom_pose": a[:, 1:4], "odom_twist": np.zeros((len(a), 2))}


def _imu_arrays(reader, topic: str) -> dict:
    rows = []
    for m in _messages(reader, topic):
        has_orientation = m.orientation_covariance[0] != -1.0
        rows.append((_t(m.header.stamp), m.angular_velocity.z, m.linear_acceleration.x,
                     m.linear_acceleration.y, _yaw(m.orientation) if has_orientation else np.nan))
    a = np.array(sorted(rows), dtype=np.float64).reshape(-1, 5)
    yaw = a[:, 4]
    if np.isnan(yaw).any():   # no orientation: the gyro integrated
        yaw = np.r_[0.0, np.cumsum(0.5 * (a[1:, 1] + a[:-1, 1]) * np.diff(a[:, 0]))]
    return {"imu_t": a[:, 0], "imu_gyro": a[:, 1], "imu_accel": a[:, 2:4], "imu_yaw": yaw}
