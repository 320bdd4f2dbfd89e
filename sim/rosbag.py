"""Sensor logs as ROS bags, both ways: ROS 1 (.bag), ROS 2 (sqlite3) and MCAP, with the frames
and topics of a TurtleBot3, so stock TurtleBot3 configurations of ROS SLAMs run on them.

Export (`export_bag`): /scan sensor_msgs/LaserScan (stamp = first beam, time_increment and
scan_time from the lidar, +inf for no return as REP 117), /odom nav_msgs/Odometry and /tf
odom -> base_footprint, /tf_static base_footprint -> base_link -> base_scan and imu_link at the
TurtleBot3 Burger URDF's heights (latched in ROS 1, transient-local in ROS 2), /imu
sensor_msgs/Imu (gravity in linear_acceleration.z, orientation from the integrated yaw),
/ground_truth nav_msgs/Odometry in frame `map` (never in /tf), /log_epoch std_msgs/Int64.
Stamps are integer nanoseconds: epoch + the log's time, each time rounded once to the nearest
nanosecond (ROS reads stamp 0 as "no time", so a bag starts at a real epoch).
Import (`import_bag`): LaserScan or MultiEchoLaserScan (first echo), NaN and +-inf as no
return (REP 117; finite readings outside [range_min, range_max] are kept, and the SLAMs'
preprocessing drops them), the lidar's mounting from /tf_static (an
upside-down scanner flips the beam order), odometry from /odom (else /tf odom ->
base_footprint), the IMU's yaw rate and yaw, header stamps (less /log_epoch when the bag has
it), frame ids without a leading `/` (ROS 1). Needs the optional `rosbags` package
(`pip install .[ros]`).
"""
from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from worlds.yamlio import InputError
from sim.log import SensorLog, value_problem

__all__ = ["FORMATS", "DEFAULT_EPOCH", "EPOCH_TOPIC", "export_bag", "import_bag"]

FORMATS = ("ros1", "ros2", "mcap")
GRAVITY = 9.80665
_TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"
NS = 10**9
# s: the stamp of the log's time 0 (2023-11-14 22:13:20 UTC), a round real time
DEFAULT_EPOCH = 1_700_000_000
EPOCH_TOPIC = "/log_epoch"   # std_msgs/Int64: the epoch in ns, read back by import_bag
# the last second a stamp can hold: ROS 1 time's sec is uint32, ROS 2's int32
_LAST_SECOND = {"ros1": 2**32 - 1, "ros2": 2**31 - 1, "mcap": 2**31 - 1}
# m: TurtleBot3 Burger URDF (turtlebot3_description): base_joint z, scan_joint z, imu_joint z;
# the lidar's x, y, yaw come from the log, the simulated IMU sits at the robot's centre
BASE_LINK_Z = 0.010
SCAN_Z = 0.172
IMU_Z = 0.068


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
    end = _LAST_SECOND[fmt] + 1
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
    ts = _typestore(fmt)
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


# --- import ---------------------------------------------------------------------------------

_SCAN_TYPES = ("sensor_msgs/msg/LaserScan", "sensor_msgs/msg/MultiEchoLaserScan")
_TF_TYPE = "tf2_msgs/msg/TFMessage"
_ODOM_TFS = (("odom", "base_footprint"), ("odom", "base_link"))


def _frame(frame_id: str) -> str:
    """A frame id without ROS 1's leading `/` (tf2 drops it too): /base_link is base_link."""
    return frame_id[1:] if frame_id.startswith("/") else frame_id


def _ns(stamp) -> int:
    """A header stamp in integer nanoseconds."""
    return int(stamp.sec) * NS + int(stamp.nanosec)


def _seconds(ns: np.ndarray) -> np.ndarray:
    """(N,) int64 ns -> (N,) float64 s; whole seconds and fraction converted apart, so a
    stamp near 1.7e18 ns keeps what float64 can hold of it."""
    sec, frac = np.divmod(np.asarray(ns, dtype=np.int64), NS)
    return sec.astype(np.float64) + frac / 1e9


class _Clock:
    """Header stamps -> log times: the bag's epoch subtracted (0 for a bag from elsewhere),
    each stream sorted by stamp, and the stamps that ran backwards counted for a warning."""

    def __init__(self, epoch_ns: int):
        self.epoch_ns = epoch_ns
        self.backwards: dict[str, tuple[int, int]] = {}   # topic -> (backward steps, messages)

    def order(self, topic: str, stamps: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """(the index that sorts `stamps` (ns), the sorted log times in s)."""
        ns = np.asarray(stamps, dtype=np.int64).reshape(-1) - self.epoch_ns
        back = int(np.count_nonzero(np.diff(ns) < 0))
        if back:
            self.backwards[topic] = (back, len(ns))
        idx = np.argsort(ns, kind="stable")
        return idx, _seconds(ns[idx])

    def warning(self) -> str | None:
        """One line on the streams that were re-sorted, or None."""
        if not self.backwards:
            return None
        parts = ", ".join(f"{topic} {back} of {n}" for topic, (back, n) in sorted(self.backwards.items()))
        return (f"header stamps out of order, messages sorted by stamp ({parts} messages stamped "
                "earlier than the one before)")


def _yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _planar(tr) -> tuple[float, float, float, bool]:
    """(x, y, yaw, upside_down) of a geometry_msgs/Transform seen from above."""
    q = tr.rotation
    # the yaw is the rotated x axis's; the rotated z axis pointing down, an upside-down mount
    return tr.translation.x, tr.translation.y, _yaw(q), 1 - 2 * (q.x * q.x + q.y * q.y) < 0


def _pick(topics: dict, given: str | None, types: tuple, prefer: str, what: str, path: Path,
          required: bool) -> str | None:
    """The topic to read: `given` (checked), else `prefer` if it has the type, else the first
    topic of the type by name; None when there is none and it is not required."""
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
    while f in static and f not in seen and f != "base_footprint":
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
    docstring); InputError naming the bag (and topic) on anything it cannot use. What it chose
    without being told (one of several scan topics, a re-sort by stamp) is listed, one line
    each, in meta.import_warnings."""
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


def _pick_scan(topics: dict, given: str | None, path: Path, warnings: list[str]) -> str:
    """The scan topic (`_pick`); with several scan topics and none given, a warning naming the
    one taken and the others."""
    topic = _pick(topics, given, _SCAN_TYPES, "/scan", "laser scan", path, True)
    others = [t for t, m in sorted(topics.items()) if m in _SCAN_TYPES and t != topic]
    if given is None and others:
        warnings.append(f"{len(others) + 1} laser scan topics: took {topic}, not "
                        f"{', '.join(others)} (--topic chooses)")
    return topic


def _epoch_ns(reader, topics: dict, p: Path) -> int | None:
    """The epoch (ns) an export recorded on EPOCH_TOPIC, or None: a bag from elsewhere;
    InputError when it is not a ROS 1 time."""
    if topics.get(EPOCH_TOPIC) != "std_msgs/msg/Int64":
        return None
    for msg in _messages(reader, EPOCH_TOPIC):
        epoch = int(msg.data)
        if not 0 <= epoch <= _LAST_SECOND["ros1"] * NS:
            raise InputError(f"{p}: {EPOCH_TOPIC}: {epoch} ns is not a time a bag can hold")
        return epoch
    return None


def _static_frames(reader, topics: dict) -> dict:
    """child frame -> (parent, x, y, yaw, upside down) from /tf_static, frames without `/`."""
    static = {}
    if topics.get("/tf_static") == _TF_TYPE:
        for msg in _messages(reader, "/tf_static"):
            for tf in msg.transforms:
                static[_frame(tf.child_frame_id)] = (_frame(tf.header.frame_id), *_planar(tf.transform))
    return static


def _read(reader, p: Path, scan_topic, odom_topic, imu_topic) -> SensorLog:
    """The SensorLog of an open bag (import_bag); warnings go to meta.import_warnings."""
    topics = {c.topic: c.msgtype for c in reader.connections}
    warnings: list[str] = []
    scan_topic = _pick_scan(topics, scan_topic, p, warnings)
    odom_topic = _pick(topics, odom_topic, ("nav_msgs/msg/Odometry",), "/odom", "odometry", p, False)
    if odom_topic == "/ground_truth":
        odom_topic = None
    imu_topic = _pick(topics, imu_topic, ("sensor_msgs/msg/Imu",), "/imu", "IMU", p, False)
    epoch = _epoch_ns(reader, topics, p)
    clock = _Clock(epoch or 0)
    arrays, lidar = _scan_arrays(reader, topics, scan_topic, clock, p)
    arrays.update(_odometry_arrays(reader, topics, odom_topic, clock))
    if imu_topic:
        arrays.update(_imu_arrays(reader, imu_topic, clock))
    if topics.get("/ground_truth") == "nav_msgs/msg/Odometry":
        t, pose, _ = _odom_rows(reader, "/ground_truth", clock)
        arrays.update(gt_t=t, gt_pose=pose)
    resorted = clock.warning()
    if resorted:
        warnings.append(resorted)
    gt = arrays.get("gt_pose", np.zeros((0, 3)))
    meta = {"lidar": lidar, "source": {"bag": str(p), "scan_topic": scan_topic,
                                        "odom_topic": odom_topic, "imu_topic": imu_topic,
                                        "epoch_ns": epoch},
            "start_pose": [float(v) for v in gt[0]] if len(gt) else None,
            "import_warnings": warnings}
    log = SensorLog(**arrays, meta=meta)
    problem = value_problem(log)
    if problem:
        raise InputError(f"{p}: {problem}")
    return log


def _scan_rows(reader, topic: str, multi: bool, clock: _Clock, p: Path):
    """(stamps ns, (N, beams) ranges with +inf for no return, messages) of the scan topic, in
    bag order; InputError when the beam count changes."""
    stamps, rows, msgs = [], [], []
    for msg in _messages(reader, topic):
        ranges = (np.array([e.echoes[0] if len(e.echoes) else np.inf for e in msg.ranges])
                  if multi else np.asarray(msg.ranges, dtype=np.float64))
        if rows and len(ranges) != len(rows[0]):
            t = (_ns(msg.header.stamp) - clock.epoch_ns) / NS
            raise InputError(f"{p}: {topic}: the scan at {t:.3f} s has {len(ranges)} beams, "
                             f"the first had {len(rows[0])}")
        # REP 117: NaN (no measurement), -inf (too close) and +inf (nothing in range) are all no
        # return; finite readings outside [range_min, range_max] stay as read, for the SLAMs'
        # preprocessing drops them (and a round trip keeps the log as it was)
        bad = ~np.isfinite(ranges) | (ranges < 0)
        stamps.append(_ns(msg.header.stamp))
        rows.append(np.where(bad, np.inf, ranges))
        msgs.append(msg)
    if not rows:
        raise InputError(f"{p}: {topic}: no messages")
    return stamps, np.vstack(rows), msgs


def _scan_arrays(reader, topics: dict, topic: str, clock: _Clock, p: Path) -> tuple[dict, dict]:
    """(scan_t, scan_ranges and scan_angles by name, meta.lidar) of the scan topic, the
    mounting read from /tf_static."""
    stamps, ranges, msgs = _scan_rows(reader, topic, topics[topic].endswith("MultiEchoLaserScan"), clock, p)
    idx, t = clock.order(topic, stamps)
    geometry, first = msgs[0], msgs[idx[0]]
    frame = _frame(geometry.header.frame_id)
    angles = geometry.angle_min + geometry.angle_increment * np.arange(ranges.shape[1])
    offset, flip = _scan_frame_offset(_static_frames(reader, topics), frame)
    if flip:
        angles = -angles
    lidar = {"beams": int(ranges.shape[1]), "range_min": float(first.range_min),
             "range_max": float(max(m.range_max for m in msgs)), "offset": [float(v) for v in offset],
             "time_increment": float(abs(first.time_increment)), "scan_time": float(first.scan_time),
             "frame": frame, "upside_down": bool(flip)}
    return {"scan_t": t, "scan_ranges": ranges[idx], "scan_angles": angles}, lidar


def _odom_rows(reader, topic: str, clock: _Clock):
    """(times (M,), poses (M, 3), twists (M, 2): v, w) of a nav_msgs/Odometry topic."""
    stamps, rows = [], []
    for m in _messages(reader, topic):
        stamps.append(_ns(m.header.stamp))
        rows.append((m.pose.pose.position.x, m.pose.pose.position.y, _yaw(m.pose.pose.orientation),
                     m.twist.twist.linear.x, m.twist.twist.angular.z))
    idx, t = clock.order(topic, stamps)
    a = np.array(rows, dtype=np.float64).reshape(-1, 5)[idx]
    return t, a[:, 0:3], a[:, 3:5]


def _odometry_arrays(reader, topics: dict, odom_topic: str | None, clock: _Clock) -> dict:
    """odom_t, odom_pose, odom_twist from `odom_topic`, else from /tf odom -> base_footprint
    (or base_link) with zero twist; {} when the bag has neither."""
    if odom_topic:
        t, pose, twist = _odom_rows(reader, odom_topic, clock)
        return {"odom_t": t, "odom_pose": pose, "odom_twist": twist}
    if topics.get("/tf") != _TF_TYPE:
        return {}
    stamps, rows = [], []
    for msg in _messages(reader, "/tf"):
        for tf in msg.transforms:
            if (_frame(tf.header.frame_id), _frame(tf.child_frame_id)) in _ODOM_TFS:
                stamps.append(_ns(tf.header.stamp))
                rows.append(_planar(tf.transform)[:3])
    if not rows:
        return {}
    idx, t = clock.order("/tf", stamps)
    return {"odom_t": t, "odom_pose": np.array(rows, dtype=np.float64)[idx],
            "odom_twist": np.zeros((len(t), 2))}


def _imu_arrays(reader, topic: str, clock: _Clock) -> dict:
    """imu_t, imu_gyro, imu_accel, imu_yaw (the orientation's, else the integrated gyro)."""
    stamps, rows = [], []
    for m in _messages(reader, topic):
        has_orientation = m.orientation_covariance[0] != -1.0
        stamps.append(_ns(m.header.stamp))
        rows.append((m.angular_velocity.z, m.linear_acceleration.x, m.linear_acceleration.y,
                     _yaw(m.orientation) if has_orientation else np.nan))
    idx, t = clock.order(topic, stamps)
    a = np.array(rows, dtype=np.float64).reshape(-1, 4)[idx]
    yaw = a[:, 3]
    if np.isnan(yaw).any():   # no orientation: the gyro integrated
        yaw = np.r_[0.0, np.cumsum(0.5 * (a[1:, 0] + a[:-1, 0]) * np.diff(t))]
    return {"imu_t": t, "imu_gyro": a[:, 0], "imu_accel": a[:, 1:3], "imu_yaw": yaw}
