"""sim: a pymunk TurtleBot3-Burger-like robot with lidar, IMU and wheel odometry that
drives a world's route and records a SensorLog (.npz).

    log = record(world, seed=0, noise="realistic", config=None, lidar="utm-30lx")
    write_log(log, "log.npz"); log = read_log("log.npz")

The sensor log and the outside formats (sim.logs) load with the package; the simulator's names
load on first use (PEP 562), so a reader of logs (slam) never imports pymunk.
"""
import importlib
import sys
import types

from sim.logs import FORMAT_VERSION, SensorLog, read_log, write_log

__all__ = ["record", "recording_problem", "MIN_COVERAGE", "RecordConfig", "load_record_config",
           "SIM_VERSION", "NoiseProfile", "load_profile", "profile_names", "SensorLog", "read_log",
           "write_log", "FORMAT_VERSION", "LidarConfig", "load_lidar", "lidar_names"]

# the simulator's public names -> the module that defines each, imported when first asked for
_LAZY = {name: "sim.record" for name in ("record", "recording_problem", "MIN_COVERAGE",
                                         "RecordConfig", "load_record_config", "SIM_VERSION")}
_LAZY.update({name: "sim.noise" for name in ("NoiseProfile", "load_profile", "profile_names")})
_LAZY.update({name: "sim.lidar" for name in ("LidarConfig", "load_lidar", "lidar_names")})


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'sim' has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


class _Package(types.ModuleType):
    """sim.record stays the function: importing the submodule sim.record would otherwise set
    the package's attribute `record` to the module (the module stays sys.modules["sim.record"])."""

    def __setattr__(self, name: str, value) -> None:
        if name in _LAZY and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
