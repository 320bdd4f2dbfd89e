"""The sensor classes the derived-defaults tests read (slam.sensors.SensorFacts): a simulated
LDS-01 log, a UTM-30LX, a CARMEN .gfs of a SICK LMS, and a log without odometry."""
import dataclasses
import math

from slam.range_noise import RangeNoise
from slam.sensors import SensorFacts

LDS01 = SensorFacts(
    range_min=0.12, range_max=3.5, beams=360, angle_increment=math.radians(1.0),
    field_of_view=2 * math.pi, scan_rate=5.0, time_increment=0.2 / 360,
    range_noise=RangeNoise(bands=((0.5, 0.015, 0.0), (3.5, 0.0, 0.05))), noise_known=True,
    median_range=0.8, odometry=True, odom_rate=30.0, imu=True, imu_rate=100.0,
    scan_step=0.04, scan_turn=0.03)
UTM30LX = dataclasses.replace(
    LDS01, range_min=0.1, range_max=30.0, beams=1081, angle_increment=math.radians(0.25),
    field_of_view=math.radians(270.25), scan_rate=40.0, time_increment=0.025 / 1440,
    range_noise=RangeNoise(bands=((10.0, 0.03, 0.0), (30.0, 0.05, 0.0))), scan_step=0.005)
# a CARMEN .gfs of a SICK LMS: 180 degrees, 80 m, one scan a metre, no IMU, no beam timing
SICK_GFS = dataclasses.replace(
    LDS01, range_min=0.0, range_max=80.0, beams=361, angle_increment=math.radians(0.5),
    field_of_view=math.radians(180.5), scan_rate=1.2, time_increment=0.0,
    range_noise=RangeNoise(stddev=0.005, bands=((80.0, 0.015, 0.0),)), median_range=2.0,
    imu=False, imu_rate=0.0, scan_step=1.0, scan_turn=0.3)
NO_ODOMETRY = dataclasses.replace(UTM30LX, odometry=False, odom_rate=0.0, scan_step=0.0, scan_turn=0.0)

CLASSES = (LDS01, UTM30LX, SICK_GFS, NO_ODOMETRY)
