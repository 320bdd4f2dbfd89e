"""2D lidar SLAM: one interface (slam.base), the shared core (occupancy grid, ray insertion,
interpolation, scan preprocessing, output-map building) and the algorithms registered by
name: `oracle` (true poses), `gn` (Hector family), `pf` (Gmapping family), `graph`
(Cartographer family). `run_algorithm(name, log, config, seed)` runs one; `write_result`
writes map.yaml + map.pgm, trajectory.tum, stats.json and config.yaml."""
from slam.base import ALGORITHMS, SlamResult, load_config, register, run, run_algorithm
from slam.io import read_result, write_result

__all__ = ["ALGORITHMS", "SlamResult", "load_config", "register", "run", "run_algorithm",
           "write_result", "read_result"]
