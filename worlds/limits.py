"""Resource bounds, checked before anything large is allocated (docs/formats.md, "Limits").

MAX_GRID_CELLS: the largest grid (rows x cols) a world's true map, a map file or a SLAM's map
may have: 20 million cells (160 MB per float64 layer; a 220 m x 220 m area at 0.05 m;
rendering one peaks near 0.7 GB, so that every command stays under 1 GB).
MAX_COORDINATE: how far from the origin a position may be, 1,000 km in metres.
MAX_ROUTE_CELLS: the largest free space (cells) the route planner takes on: 4 million cells
(10,000 m² at 0.05 m); larger worlds need a `route:` in their YAML.
Both can be raised for one process with the environment variables SLAM_BENCH_MAX_CELLS and
SLAM_BENCH_MAX_ROUTE_CELLS.
"""
from __future__ import annotations

import os

from worlds.yamlio import InputError

__all__ = ["max_grid_cells", "max_route_cells", "check_grid_cells", "MAX_COORDINATE",
           "MAX_RESOLUTION", "check_coordinates"]

# metres from the origin any position may lie (a world, a map's corner, a trajectory): far
# beyond any building, near enough that sums of coordinates stay finite and exact to 0.1 mm
MAX_COORDINATE = 1e6
# the coarsest grid cell (m): coarser is a mistake, and products with cell counts overflow
MAX_RESOLUTION = 100.0


def _limit(env: str, default: int) -> int:
    text = os.environ.get(env, "")
    if not text:
        return default
    try:
        value = int(float(text))
    except ValueError:
        raise InputError(f"{env}: expected a number of cells, got {text!r}") from None
    if value < 1:
        raise InputError(f"{env}: expected a number of cells >= 1, got {text!r}")
    return value


def max_grid_cells() -> int:
    """The largest grid, in cells (SLAM_BENCH_MAX_CELLS, default 20 million)."""
    return _limit("SLAM_BENCH_MAX_CELLS", 20_000_000)


def max_route_cells() -> int:
    """The largest free space the route planner takes on, in cells (SLAM_BENCH_MAX_ROUTE_CELLS,
    default 4 million)."""
    return _limit("SLAM_BENCH_MAX_ROUTE_CELLS", 4_000_000)


def check_grid_cells(rows: int, cols: int, where: str, cause: str) -> None:
    """InputError '<where>: <cause> needs a grid of R x C cells, more than the limit of N
    (SLAM_BENCH_MAX_CELLS)' when rows x cols exceeds max_grid_cells()."""
    limit = max_grid_cells()
    if rows * cols > limit:
        raise InputError(f"{where}: {cause} needs a grid of {rows:,} x {cols:,} cells, more than "
                         f"the limit of {limit:,} (raise it with SLAM_BENCH_MAX_CELLS)")


def check_coordinates(values, where: str, field: str) -> None:
    """InputError '<where>: <field>: ...' unless every value is finite and within
    MAX_COORDINATE metres of 0."""
    import numpy as np
    v = np.asarray(values, dtype=np.float64)
    bad = ~np.isfinite(v) | (np.abs(v) > MAX_COORDINATE)
    if np.any(bad):
        worst = float(v[bad].flat[0])
        raise InputError(f"{where}: {field}: {worst!r} is not a position within {MAX_COORDINATE:g} m "
                         "of the origin")
