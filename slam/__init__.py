"""2D lidar SLAM: one contract (slam.base.Slam), a registry of algorithms by name
(slam.registry: `oracle`, `gn` Hector family, `pf` Gmapping family, `graph` Cartographer
family, and entry-point plugins), the shared components (pose algebra, scan preprocessing,
occupancy grids, Gauss-Newton kernels, the output map) and the replay loop.
`run_algorithm(name, log, config, seed)` runs one; `write_result` writes map.yaml + map.pgm,
trajectory.tum, stats.json and config.yaml."""
from slam.base import Slam, SlamResult
from slam.io import read_result, write_result
from slam.registry import algorithms, load_config, names, register
from slam.replay import run, run_algorithm

__all__ = ["Slam", "SlamResult", "algorithms", "names", "load_config", "register", "run",
           "run_algorithm", "write_result", "read_result"]
