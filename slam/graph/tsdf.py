"""TSDF submaps of the local SLAM (Cartographer's TSDF2D with TSDFRangeDataInserter2D).

A truncated signed distance field stores, per cell, the weighted mean signed distance to the
nearest surface along the scans' normals (positive in front, +-truncation at most) and the
summed weight. The surface is the zero crossing of the bilinearly interpolated field, so it
lies between cell centres where the hits put it: a probability grid can only say which cells
were hit, and puts a wall at the centres of its hit cells, up to half a cell from where it is.
The kernels are in slam.graph._tsdf_kernel.

The scan matchers read a TSDF submap through three grids of the same meta as a probability
submap:
- probabilities(): 1 - tsd / truncation for the least squares, whose residual 1 - M is then
  tsd / truncation (Cartographer's TSDFMatchCostFunction2D; never-observed cells read 0);
- search_grid(): 1 - |tsd| / truncation in [0, 1], the score of the correlative searches
  (Cartographer's correspondence cost of a TSDF cell);
- probability_at(): 1 - tsd / truncation clipped to [0, 1]: near 0 well in front of a surface,
  1 on and behind it (what the loop closures' see-through check asks for).
"""
from __future__ import annotations

import numpy as np

from slam.graph._tsdf_kernel import cells_under, estimate_normals, tsdf_insert
from slam.occupancy import GrowingGrid

__all__ = ["TsdfGrid", "TsdfSubmap", "tsdf_scan", "scan_normals"]


class TsdfGrid(GrowingGrid):
    """A growing TSDF: layers tsd (m), weight, the id of the scan that last updated a cell, and
    match = 1 - tsd / truncation (the least squares' grid, kept up to date by the insertion);
    with directions K > 0 also the directional layers dir_tsd, dir_weight, dir_stamp
    (K, rows, cols), one field per normal direction 2 pi k / K."""

    def __init__(self, resolution: float, center, truncation: float, directions: int = 0, **kw):
        self.truncation = float(truncation)
        self.directions = int(directions)
        self.scans = 0
        super().__init__(resolution, center, **kw)
        self._meta = (None, None)

    @property
    def meta(self) -> np.ndarray:
        """(5,) [ox, oy, resolution, rows, cols] for the kernels, kept until the grid grows
        (the matchers ask for it on every scan)."""
        key = (self._i0, self._j0, self.tsd.shape)
        if self._meta[0] != key:
            self._meta = (key, GrowingGrid.meta.fget(self))
        return self._meta[1]

    def _layers(self) -> tuple:
        k = self.directions
        return (("tsd", self.truncation, np.float64), ("weight", 0.0, np.float64), ("stamp", 0, np.int32),
                ("match", 0.0, np.float64), ("dir_tsd", self.truncation, np.float64, k),
                ("dir_weight", 0.0, np.float64, k), ("dir_stamp", 0, np.int32, k))

    def insert(self, origin_xy: np.ndarray, hits_xy: np.ndarray, opts) -> int:
        """Insert the hits (N, 2) of one scan taken from origin (2,), world frame m; opts: a
        TsdfInserterConfig. Returns the number of cell updates."""
        return self.insert_sorted(*tsdf_scan(origin_xy, hits_xy, opts), opts)

    def insert_sorted(self, origin: np.ndarray, hits: np.ndarray, normals: np.ndarray, opts) -> int:
        """insert() of a scan already put in the inserter's form by tsdf_scan."""
        self.scans += 1
        if len(hits) == 0:
            return 0
        allp = np.vstack([hits, origin[None, :]])
        self.ensure(allp.min(axis=0) - self.truncation, allp.max(axis=0) + self.truncation)
        n = tsdf_insert(self.tsd, self.weight, self.stamp, self.match, self.scans, self.meta, origin, hits,
                        normals, self.truncation, float(opts.maximum_weight),
                        float(opts.update_weight_angle_scan_normal_to_ray_kernel_bandwidth),
                        float(opts.update_weight_distance_cell_to_hit_kernel_bandwidth), self.dir_tsd,
                        self.dir_weight, self.dir_stamp)
        self.version += 1
        return int(n)


def _bearing_order(origin: np.ndarray, hits: np.ndarray) -> np.ndarray:
    """Indices of the hits (N, 2) in bearing order from origin (2,), ties in input order."""
    return np.argsort(np.arctan2(hits[:, 1] - origin[1], hits[:, 0] - origin[0]), kind="mergesort")


def tsdf_scan(origin_xy: np.ndarray, hits_xy: np.ndarray, opts) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One scan as the TSDF inserter takes it: (origin (2,), hits (N, 2) in bearing order from
    the origin, their normal angles (N,) rad); opts: a TsdfInserterConfig. Computed once for
    the two active submaps a scan goes into."""
    origin = np.ascontiguousarray(np.asarray(origin_xy, np.float64)[:2])
    hits = np.asarray(hits_xy, np.float64).reshape(-1, 2)
    if len(hits) == 0:
        return origin, hits, np.zeros(0)
    hits = np.ascontiguousarray(hits[_bearing_order(origin, hits)])
    normals = estimate_normals(origin, hits, int(opts.num_normal_samples), float(opts.sample_radius))
    return origin, hits, normals


def scan_normals(origin_xy: np.ndarray, hits_xy: np.ndarray, opts) -> np.ndarray:
    """(N,) normal angles (rad, the hits' frame) of the hits (N, 2) seen from origin (2,), in
    their order, estimated as the TSDF insertion estimates them (in bearing order); opts: a
    TsdfInserterConfig."""
    origin = np.asarray(origin_xy, np.float64)[:2]
    hits = np.asarray(hits_xy, np.float64).reshape(-1, 2)
    order = _bearing_order(origin, hits)
    out = np.empty(len(hits))
    out[order] = estimate_normals(np.ascontiguousarray(origin), np.ascontiguousarray(hits[order]),
                                  int(opts.num_normal_samples), float(opts.sample_radius))
    return out


class TsdfSubmap:
    """One TSDF submap in the local frame, with the interface of slam.graph.submaps.Submap."""

    def __init__(self, index: int, origin_xy: np.ndarray, cfg):
        self.index = index
        self.local_pose = np.array([origin_xy[0], origin_xy[1], 0.0])
        self.cfg = cfg
        self.grid = TsdfGrid(cfg.resolution, center=tuple(origin_xy[:2]), truncation=cfg.tsdf.truncation_distance,
                             directions=cfg.tsdf.normal_directions,
                             block=32, size=8.0, margin=0.3)
        self.num_range_data = 0
        self.finished = False
        self._cache: dict = {}

    def insert(self, origin_xy: np.ndarray, hits_xy: np.ndarray, misses_xy: np.ndarray) -> None:
        """Insert one scan: origin (2,), hits (N, 2), misses (ignored: no free-space update, as
        Cartographer's default update_free_space = false), all local frame m."""
        self.insert_prepared(self.prepare(origin_xy, hits_xy, misses_xy))

    def prepare(self, origin_xy: np.ndarray, hits_xy: np.ndarray, misses_xy: np.ndarray) -> tuple:
        """The scan in the form insert_prepared takes (the same for every TSDF submap)."""
        return tsdf_scan(origin_xy, hits_xy, self.cfg.tsdf)

    def insert_prepared(self, scan: tuple) -> None:
        """Insert a scan from prepare()."""
        if self.finished:
            raise RuntimeError(f"submap {self.index} is finished")
        self.grid.insert_sorted(*scan, self.cfg.tsdf)
        self.num_range_data += 1

    def _cached(self, name, make):
        version, value = self._cache.get(name, (-1, None))
        if version != self.grid.version:
            value = np.ascontiguousarray(make())
            self._cache[name] = (self.grid.version, value)
        return value

    def probabilities(self) -> tuple[np.ndarray, np.ndarray]:
        """((rows, cols) 1 - tsd / truncation, never observed 0; (5,) grid meta)."""
        return self.grid.match, self.grid.meta

    def directional(self) -> tuple | None:
        """(dir_tsd, dir_weight (K, rows, cols), truncation, (5,) grid meta) of the directional
        layers, or None without them."""
        g = self.grid
        return (g.dir_tsd, g.dir_weight, g.truncation, g.meta) if g.directions > 0 else None

    def search_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """((rows, cols) 1 - |tsd| / truncation in [0, 1], never observed 0; (5,) grid meta)."""
        g = self.grid
        return self._cached("search", lambda: 1.0 - np.abs(g.tsd) / g.truncation), g.meta

    def known_at(self, xy: np.ndarray) -> np.ndarray:
        """(N,) bool: the cell under each point (N, 2) local frame m has been observed."""
        r, c, inside = cells_under(self.grid.meta, np.ascontiguousarray(xy, np.float64))
        return inside & (self.grid.weight[r, c] > 0)

    def probability_at(self, xy: np.ndarray) -> np.ndarray:
        """(N,) 1 - tsd / truncation clipped to [0, 1] under each point; NaN where never observed."""
        r, c, inside = cells_under(self.grid.meta, np.ascontiguousarray(xy, np.float64))
        p = np.clip(1.0 - self.grid.tsd[r, c] / self.grid.truncation, 0.0, 1.0)
        return np.where(inside & (self.grid.weight[r, c] > 0), p, np.nan)
