"""What ROS bag export (sim.logs.ros_export) and import (sim.logs.ros_import) share: the
optional `rosbags` package and its message types, stamps as integer nanoseconds, and the topic
an export records its epoch on.

Both need `rosbags` (`pip install .[ros]`); it is imported only when a bag is read or written.
"""
from __future__ import annotations

from worlds.yamlio import InputError

__all__ = ["NS", "EPOCH_TOPIC", "LAST_SECOND", "require_rosbags", "typestore"]

NS = 10**9
EPOCH_TOPIC = "/log_epoch"   # std_msgs/Int64: the epoch in ns, read back by import_bag
# the last second a stamp can hold: ROS 1 time's sec is uint32, ROS 2's int32
LAST_SECOND = {"ros1": 2**32 - 1, "ros2": 2**31 - 1, "mcap": 2**31 - 1}
_TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"


def require_rosbags():
    """(Stores, get_types_from_msg, get_typestore) of rosbags.typesys; InputError naming the
    extra to install when rosbags is missing."""
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise InputError("ROS bags need the optional package rosbags: pip install .[ros]") from None
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    return Stores, get_types_from_msg, get_typestore


def typestore(fmt: str):
    """The rosbags type store of bag format `fmt` (ros1: Noetic, ros2 and mcap: Humble), with
    tf2_msgs/TFMessage registered where the store lacks it."""
    stores, get_types_from_msg, get_typestore = require_rosbags()
    ts = get_typestore(stores.ROS1_NOETIC if fmt == "ros1" else stores.ROS2_HUMBLE)
    if "tf2_msgs/msg/TFMessage" not in ts.types:
        ts.register(get_types_from_msg(_TF_MSG, "tf2_msgs/msg/TFMessage"))
    return ts
