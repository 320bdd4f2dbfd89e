"""ROS bags into sensor logs (`import_bag`): ROS 1 (.bag), ROS 2 (sqlite3) and MCAP, as
exported by sim.logs.ros_export or recorded elsewhere.

LaserScan or MultiEchoLaserScan (first echo), NaN and +-inf as no return (REP 117; finite
readings outside [range_min, range_max] are kept, and the SLAMs' preprocessing drops them), the
lidar's mounting from /tf_static (an upside-down scanner flips the beam order), odometry from
/odom (else /tf odom -> base_footprint), the IMU's yaw rate and yaw, header stamps (less
/log_epoch when the bag has it), frame ids without a leading `/` (ROS 1). Needs the optional
`rosbags` package (`pip install .[ros]`).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from worlds.yamlio import InputError
from sim.logs.ros_msgs import EPOCH_TOPIC, LAST_SECOND, NS, require_rosbags
from sim.logs.sensorlog import SensorLog, value_problem

__all__ = ["import_bag"]

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
    require_rosbags()
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
        if not 0 <= epoch <= LAST_SECOND["ros1"] * NS:
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
