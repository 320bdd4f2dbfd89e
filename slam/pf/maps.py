"""Per-particle maps sharing memory by copy-on-write tiles (see slam/pf/_map_kernel.py).

`TiledMaps(n, extent, resolution, tile)` holds N count maps over a fixed square of side
2 * extent centred on the start (Gmapping's xmin..xmax, ymin..ymax). Resampling copies only
the small tile tables; a tile is duplicated when a particle writes into one it shares.
With 30 particles and tiles of 16 x 16 cells (4 kB), a 50 m x 50 m map costs one full map
(15 MB) plus the tiles the particles have rewritten since their common ancestors.
"""
from __future__ import annotations

import numpy as np

from worlds.limits import check_grid_cells
from slam.pf._map_kernel import N_FIELDS, insert_scans, tiles_bound

__all__ = ["TiledMaps"]


class TiledMaps:
    """N particles' count maps. tables (N, TR, TC) int32 pool indices; pool (cap, T, T, 4)."""

    def __init__(self, n: int, center: np.ndarray, extent: float, resolution: float,
                 tile: int = 16, capacity: int = 256):
        self.tile = int(tile)
        if self.tile < 1 or self.tile & (self.tile - 1):
            raise ValueError(f"tile must be a power of two, got {tile}")
        n_tiles = int(np.ceil(2 * extent / (resolution * tile)))
        rows = cols = n_tiles * self.tile
        check_grid_cells(rows, cols, "pf", f"map_extent {extent:g} m at delta {resolution:g} m")
        # the lower-left corner on the world's lattice (multiples of the resolution), as the
        # true map and the other algorithms' grids: a map rasterized on a lattice shifted by
        # part of a cell puts a wall's face in another cell than the true map does
        ox = round((float(center[0]) - rows * resolution / 2) / resolution) * resolution
        oy = round((float(center[1]) - rows * resolution / 2) / resolution) * resolution
        self.grid_meta = np.array([ox, oy, resolution, rows, cols, self.tile.bit_length() - 1],
                                  dtype=np.float64)
        self.tables = np.full((n, n_tiles, n_tiles), -1, dtype=np.int32)
        self.pool = np.zeros((capacity, tile, tile, N_FIELDS), dtype=np.float32)
        self.refcount = np.zeros(capacity, dtype=np.int32)

    @property
    def n(self) -> int:
        return self.tables.shape[0]

    def resample(self, ancestors: np.ndarray) -> None:
        """Particle i takes the map of particle ancestors[i] (shares its tiles)."""
        self.tables = self.tables[np.asarray(ancestors)]
        self._recount()

    def _recount(self) -> None:
        t = self.tables[self.tables >= 0]
        self.refcount = np.bincount(t, minlength=len(self.pool)).astype(np.int32)

    def _reserve(self, needed: int) -> np.ndarray:
        """Free pool slots, growing the pool (doubling) until `needed` are available."""
        free = np.flatnonzero(self.refcount == 0)
        if len(free) < needed:
            cap = len(self.pool)
            new_cap = max(2 * cap, cap + needed - len(free) + 64)
            pool = np.zeros((new_cap, *self.pool.shape[1:]), dtype=np.float32)
            pool[:cap] = self.pool
            self.pool = pool
            self.refcount = np.concatenate([self.refcount, np.zeros(new_cap - cap, np.int32)])
            free = np.flatnonzero(self.refcount == 0)
        return free.astype(np.int64)

    def insert(self, poses: np.ndarray, origin: np.ndarray, ends: np.ndarray,
               hit: np.ndarray) -> None:
        """Insert one scan into every particle's map at its pose.

        poses: (N, 3); origin: (2,) lidar in the robot frame; ends: (K, 2) beam ends in the
        robot frame; hit: (K,) True where the beam ends on a return (False: free space only).
        """
        poses = np.ascontiguousarray(poses, dtype=np.float64).reshape(-1, 3)
        ends = np.ascontiguousarray(ends, dtype=np.float64).reshape(-1, 2)
        origin = np.ascontiguousarray(origin, dtype=np.float64)
        hit = np.ascontiguousarray(hit, dtype=np.bool_)
        free = self._reserve(tiles_bound(self.grid_meta, poses, origin, ends))
        insert_scans(self.tables, self.pool, self.refcount, free, self.grid_meta, poses, origin,
                     ends, hit)

    def dense(self, i: int) -> np.ndarray:
        """(rows, cols, 4) float64 counters of particle i (hits, visits, sum dx, sum dy)."""
        tr, tc = self.tables.shape[1:]
        t = self.tile
        out = np.zeros((tr * t, tc * t, N_FIELDS))
        for a, b in zip(*np.nonzero(self.tables[i] >= 0)):
            out[a * t:(a + 1) * t, b * t:(b + 1) * t] = self.pool[self.tables[i, a, b]]
        return out

    def memory_bytes(self) -> int:
        """Bytes held by the tile pool and the tables."""
        return int(self.pool.nbytes + self.tables.nbytes + self.refcount.nbytes)

    def tiles_in_use(self) -> int:
        return int(np.count_nonzero(self.refcount))
