"""sim.logs: the sensor log every SLAM reads and every outside file format, apart from the
simulator (importing it loads neither pymunk nor the robot).

    sensorlog.py   SensorLog: the recorded arrays and their shape rules; world_ref
    checks.py      the rules a log's values follow, applied by every reader and writer
    npz.py         read_log / write_log: the versioned .npz, sizes checked before reading
    carmen.py      CARMEN (.log, .clf) and GMapping .gfs logs -> SensorLog (import_log)
    ros_export.py  SensorLog -> ROS 1 bag, ROS 2 bag, MCAP (export_bag)
    ros_import.py  ROS bags -> SensorLog (import_bag)
    ros_msgs.py    what both ROS directions share: rosbags' types, stamps, the epoch topic
    tum.py         TUM trajectory text files (read_tum, write_tum)
"""
from sim.logs.carmen import import_log
from sim.logs.npz import FORMAT_VERSION, read_log, write_log
from sim.logs.ros_export import export_bag
from sim.logs.ros_import import import_bag
from sim.logs.sensorlog import SensorLog, world_ref
from sim.logs.tum import read_tum, write_tum

__all__ = ["SensorLog", "read_log", "write_log", "FORMAT_VERSION", "world_ref", "import_log",
           "import_bag", "export_bag", "read_tum", "write_tum"]
