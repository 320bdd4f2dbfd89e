"""sim: a pymunk TurtleBot3-Burger-like robot with lidar, IMU and wheel odometry that
drives a world's route and records a SensorLog (.npz).

    log = record(world, seed=0, noise="realistic", config=None)
    write_log(log, "log.npz"); log = read_log("log.npz")
"""
from sim.log import FORMAT_VERSION, SensorLog, read_log, write_log
from sim.noise import NoiseProfile, load_profile, profile_names
from sim.record import (MIN_COVERAGE, SIM_VERSION, RecordConfig, load_record_config, record,
                        recording_problem)

__all__ = ["record", "recording_problem", "MIN_COVERAGE", "RecordConfig", "load_record_config",
           "SIM_VERSION", "NoiseProfile", "load_profile", "profile_names", "SensorLog", "read_log",
           "write_log", "FORMAT_VERSION"]
