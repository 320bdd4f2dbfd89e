"""LogOddsGrid: a log-odds occupancy grid that grows as the robot explores; ReflectanceGrid:
the same lattice holding hit and visit counts (Hector's GridMapReflectanceCount).

Cells hold log-odds l = log(p / (1 - p)); NaN marks a cell no ray has touched yet. The grid
grows in whole blocks of cells, keeping its lattice (the origin moves by whole cells), so a
scan inserted anywhere always lands inside it. Ray insertion is slam._kernels.insert.

Log-odds from the probabilities SLAM packages quote (Hector's update_factor_free/occupied):
`logodds(p) = log(p / (1 - p))`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from worlds.grid import Grid
from worlds.limits import check_grid_cells
from slam._kernels.insert import insert_rays_inplace
from slam._kernels.prob import logodds_to_prob
from slam.pose import transform_points

__all__ = ["GrowingGrid", "LogOddsGrid", "ReflectanceGrid", "GridConfig", "logodds", "insert_scan_points"]


def logodds(p: float) -> float:
    """log(p / (1 - p)) of a probability in (0, 1)."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"probability must lie in (0, 1), got {p}")
    return math.log(p / (1.0 - p))


@dataclass(frozen=True)
class GridConfig:
    """An occupancy grid's parameters, as they appear in each algorithm's YAML."""

    resolution: float = 0.05   # m per cell
    p_free: float = 0.4        # occupancy probability a ray's free cell is updated with (log-odds < 0)
    p_occupied: float = 0.9    # occupancy probability a hit cell is updated with (log-odds > 0)
    l_min: float = -5.0        # log-odds clamp below (keeps cells able to change back)
    l_max: float = 5.0         # log-odds clamp above

    def __post_init__(self):
        if self.resolution <= 0:
            raise ValueError(f"resolution must be positive, got {self.resolution}")
        if not (0.0 < self.p_free < 0.5 < self.p_occupied < 1.0):
            raise ValueError(f"need 0 < p_free < 0.5 < p_occupied < 1, got {self.p_free}, {self.p_occupied}")
        if not self.l_min < 0 < self.l_max:
            raise ValueError(f"need l_min < 0 < l_max, got {self.l_min}, {self.l_max}")


class GrowingGrid:
    """Cell arrays ("layers") on a fixed lattice that grow in whole blocks as points arrive.

    resolution: m per cell; center: (2,) world x, y the first block is centred on; block:
    growth step in cells (the arrays grow by whole blocks, at least `margin` m beyond any
    point passed to `ensure`). Subclasses name their layers and fill values in `_layers()`.
    """

    def __init__(self, resolution: float, center=(0.0, 0.0), block: int = 64, size: float = 8.0,
                 margin: float = 0.5):
        if resolution <= 0:
            raise ValueError(f"resolution must be positive, got {resolution}")
        self.resolution = float(resolution)
        self.block = int(block)
        self.margin = float(margin)
        n = max(self.block, int(math.ceil(size / self.resolution / self.block)) * self.block)
        # integer cell index of the lower-left corner on the global lattice (multiples of res)
        self._i0 = int(math.floor(center[0] / self.resolution)) - n // 2
        self._j0 = int(math.floor(center[1] / self.resolution)) - n // 2
        for name, fill, dtype, *depth in self._layers():
            setattr(self, name, np.full((*depth, n, n), fill, dtype=dtype))
        self.version = 0  # bumped by every change, for callers caching derived maps

    def _layers(self) -> tuple:
        """((attribute name, fill value of new cells, dtype[, depth]), ...); a layer with a
        depth is a stack (depth, rows, cols) of grids; the first layer (no depth) sets `shape`."""
        raise NotImplementedError

    # --- geometry ---------------------------------------------------------------------
    @property
    def origin(self) -> np.ndarray:
        """(2,) world x, y of the lower-left corner of cell (0, 0)."""
        return np.array([self._i0 * self.resolution, self._j0 * self.resolution])

    @property
    def shape(self) -> tuple[int, int]:
        return getattr(self, self._layers()[0][0]).shape

    @property
    def meta(self) -> np.ndarray:
        """(5,) [ox, oy, resolution, rows, cols] for the kernels."""
        ox, oy = self.origin
        return np.array([ox, oy, self.resolution, self.shape[0], self.shape[1]], dtype=np.float64)

    def cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(row, col, inside) of the cells under points (N, 2) m; row and col are 0 outside."""
        ox, oy = self.origin
        c = np.floor((xy[:, 0] - ox) / self.resolution).astype(np.int64)
        r = np.floor((xy[:, 1] - oy) / self.resolution).astype(np.int64)
        rows, cols = self.shape
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        return np.where(inside, r, 0), np.where(inside, c, 0), inside

    def observed(self, xy: np.ndarray) -> np.ndarray:
        """(N,) bool: the cell under each point (N, 2) m has been touched by a scan (its first
        layer is not NaN); False outside the grid."""
        r, c, inside = self.cells(np.asarray(xy, dtype=np.float64).reshape(-1, 2))
        return inside & ~np.isnan(getattr(self, self._layers()[0][0])[r, c])

    def ensure(self, xy_min, xy_max) -> bool:
        """Grow so the box [xy_min, xy_max] (m) plus the margin lies inside. True if it grew."""
        res, b = self.resolution, self.block
        rows, cols = self.shape
        lo_i = int(math.floor((xy_min[0] - self.margin) / res))
        lo_j = int(math.floor((xy_min[1] - self.margin) / res))
        hi_i = int(math.floor((xy_max[0] + self.margin) / res)) + 1
        hi_j = int(math.floor((xy_max[1] + self.margin) / res)) + 1
        add_l = max(0, -(-(self._i0 - lo_i) // b)) * b
        add_b = max(0, -(-(self._j0 - lo_j) // b)) * b
        add_r = max(0, -(-(hi_i - (self._i0 + cols)) // b)) * b
        add_t = max(0, -(-(hi_j - (self._j0 + rows)) // b)) * b
        if not (add_l or add_b or add_r or add_t):
            return False
        check_grid_cells(rows + add_b + add_t, cols + add_l + add_r, "map",
                         f"a point at ({xy_max[0]:.4g}, {xy_max[1]:.4g}) m or ({xy_min[0]:.4g}, "
                         f"{xy_min[1]:.4g}) m (a pose far off)")
        for name, fill, dtype, *depth in self._layers():
            new = np.full((*depth, rows + add_b + add_t, cols + add_l + add_r), fill, dtype=dtype)
            new[..., add_b:add_b + rows, add_l:add_l + cols] = getattr(self, name)
            setattr(self, name, new)
        self._i0 -= add_l
        self._j0 -= add_b
        self.version += 1
        return True

    def _scan_rays(self, sensor_pose, points_world_xy, hit_mask):
        """(origin (2,), ends (N, 2), hits (N,) bool) of one scan's rays as the insertion kernel
        takes them (hit_mask None = all hits), the grid grown to hold them."""
        o = np.ascontiguousarray(np.asarray(sensor_pose, dtype=np.float64)[:2])
        pts = np.ascontiguousarray(np.asarray(points_world_xy, dtype=np.float64).reshape(-1, 2))
        hits = (np.ones(len(pts), dtype=np.bool_) if hit_mask is None
                else np.ascontiguousarray(np.asarray(hit_mask, dtype=np.bool_).reshape(-1)))
        if len(hits) != len(pts):
            raise ValueError(f"hit_mask has {len(hits)} entries for {len(pts)} points")
        if len(pts):
            allp = np.vstack([pts, o[None, :]])
            self.ensure(allp.min(axis=0), allp.max(axis=0))
        return o, pts, hits


class LogOddsGrid(GrowingGrid):
    """A growing log-odds occupancy grid.

    resolution: m per cell; center: (2,) world x, y the first block is centred on;
    l_free, l_occ: log-odds added to freed / hit cells; l_min, l_max: clamping bounds;
    block: growth step in cells (the grid grows by whole blocks, at least `margin` m
    beyond any inserted point).
    """

    def __init__(self, resolution: float = 0.05, center=(0.0, 0.0), l_free: float = logodds(0.4),
                 l_occ: float = logodds(0.9), l_min: float = -5.0, l_max: float = 5.0,
                 block: int = 64, size: float = 8.0, margin: float = 0.5):
        self.l_free, self.l_occ = float(l_free), float(l_occ)
        self.l_min, self.l_max = float(l_min), float(l_max)
        super().__init__(resolution, center, block, size, margin)

    def _layers(self) -> tuple:
        return (("logodds", np.nan, np.float64),)

    @classmethod
    def from_config(cls, cfg: GridConfig, center=(0.0, 0.0), **kw) -> "LogOddsGrid":
        """A grid with the resolution and update values of `cfg`, first block centred on `center`."""
        return cls(cfg.resolution, center, logodds(cfg.p_free), logodds(cfg.p_occupied),
                   cfg.l_min, cfg.l_max, **kw)

    # --- updates ----------------------------------------------------------------------
    def insert_scan(self, sensor_pose, points_world_xy, hit_mask=None,
                    free_margin: np.ndarray | None = None) -> int:
        """Insert one scan: rays from the sensor to each point.

        sensor_pose: (2,) or (3,) world pose of the lidar (only x, y are used);
        points_world_xy: (N, 2) m ray end points; hit_mask: (N,) bool, True where the ray hit
        something (occupied end cell), False for no-return rays (free to the end). Default: all hits.
        free_margin: None or (N,)
        m; a hit ray frees space only up to this far short of its end point (the range noise band,
        see slam._kernels.insert). Returns the number of cells updated.
        """
        if free_margin is not None and np.size(free_margin) != np.size(points_world_xy) // 2:
            raise ValueError(f"free_margin has {np.size(free_margin)} entries for "
                             f"{np.size(points_world_xy) // 2} points")
        o, pts, hits = self._scan_rays(sensor_pose, points_world_xy, hit_mask)
        if len(pts) == 0:
            return 0
        n = insert_rays_inplace(self.logodds, self.meta, o, pts, hits,
                                self.l_free, self.l_occ, self.l_min, self.l_max,
                                None if free_margin is None
                                else np.ascontiguousarray(free_margin, dtype=np.float64).reshape(-1))
        self.version += 1
        return int(n)

    # --- views ------------------------------------------------------------------------
    def prob(self, unknown: float = np.nan) -> np.ndarray:
        """(rows, cols) occupancy probabilities; never-touched cells get `unknown` (NaN default)."""
        return logodds_to_prob(np.ascontiguousarray(self.logodds, dtype=np.float64), float(unknown))

    def to_grid(self, crop: bool = True) -> Grid:
        """The map as a worlds.grid.Grid (NaN unknown), cropped to the touched cells plus one cell."""
        p = self.prob()
        origin = self.origin
        if crop:
            known = ~np.isnan(self.logodds)
            if known.any():
                r = np.nonzero(known.any(axis=1))[0]
                c = np.nonzero(known.any(axis=0))[0]
                r0, r1 = max(r[0] - 1, 0), min(r[-1] + 2, p.shape[0])
                c0, c1 = max(c[0] - 1, 0), min(c[-1] + 2, p.shape[1])
                p = p[r0:r1, c0:c1]
                origin = origin + np.array([c0, r0]) * self.resolution
        return Grid(p, self.resolution, np.array([origin[0], origin[1], 0.0]))

    def copy(self) -> "LogOddsGrid":
        """An independent copy (for particles)."""
        new = LogOddsGrid.__new__(LogOddsGrid)
        new.__dict__.update(self.__dict__)
        new.logodds = self.logodds.copy()
        return new


class ReflectanceGrid(GrowingGrid):
    """A growing grid of reflection counts: hector_slam's GridMapReflectanceCount.

    Every scan adds, once per cell (hits first, as LogOddsGrid), one visit to each cell its
    rays cross or end in and one reflection to each cell a hit ends in; a cell's occupancy
    is reflections / visits. Unlike log-odds, which saturate every cell hit in more than
    about a sixth of its visits (at Hector's 0.4 / 0.9 update factors), the ratio keeps the
    shape of the range noise: highest where the wall is, falling off to either side.
    """

    def _layers(self) -> tuple:
        # NaN: never visited; `reflected` becomes 0 on a cell's first visit
        return (("reflected", np.nan, np.float64), ("visited", np.nan, np.float64))

    def insert_scan(self, sensor_pose, points_world_xy, hit_mask=None) -> int:
        """Insert one scan: rays from the sensor (2,) or (3,) to each point (N, 2) m; hit_mask
        (N,) bool, False for no-return rays (default: all hits). Returns the cells visited."""
        o, pts, hits = self._scan_rays(sensor_pose, points_world_xy, hit_mask)
        if len(pts) == 0:
            return 0
        # the log-odds kernel with increments 0 / 1 and no clamping counts, with the same
        # traversal and the same once-per-scan rule
        insert_rays_inplace(self.reflected, self.meta, o, pts, hits, 0.0, 1.0, 0.0, np.inf)
        n = insert_rays_inplace(self.visited, self.meta, o, pts, hits, 1.0, 1.0, 0.0, np.inf)
        self.version += 1
        return int(n)

    def prob(self, unknown: float = np.nan) -> np.ndarray:
        """(rows, cols) reflections / visits; never-visited cells get `unknown` (NaN default)."""
        seen = ~np.isnan(self.visited)
        out = np.full(self.shape, unknown, dtype=np.float64)
        out[seen] = self.reflected[seen] / self.visited[seen]
        return out


def insert_scan_points(grid: LogOddsGrid | ReflectanceGrid, pts, pose: np.ndarray) -> None:
    """Rays from the lidar to every hit (occupied end) and miss (free end) of a preprocessed
    scan `pts` (slam.preprocess.ScanPoints) at robot `pose` (3,)."""
    sensor = transform_points(pose, pts.origin[None, :])[0]
    ends = transform_points(pose, np.vstack([pts.points, pts.misses]))
    hits = np.r_[np.ones(len(pts.points), bool), np.zeros(len(pts.misses), bool)]
    grid.insert_scan(sensor, ends, hits)
