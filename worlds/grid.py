"""Grid: the one occupancy-map type every stage shares.

Conventions (docs/formats.md): `prob[row, col]`, row 0 at the bottom (y grows with row),
probabilities in [0, 1], NaN = unknown. `origin` is the world pose (x, y, yaw) of the
lower-left corner of cell (0, 0), as in ROS map_server. A cell is occupied at
p >= occupied_thresh (default 0.65) and free at p <= free_thresh (default 0.2), the
thresholds of the reference study; unknown cells are neither.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Grid", "OCCUPIED_THRESH", "FREE_THRESH"]

OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.2


@dataclass(frozen=True, eq=False)
class Grid:
    """An occupancy grid.

    prob: (rows, cols) float64 in [0, 1], NaN where unknown; resolution: m per cell;
    origin: (3,) world pose x, y, yaw of the lower-left corner of cell (0, 0).
    """

    prob: np.ndarray
    resolution: float = 0.05
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        prob = np.asarray(self.prob, dtype=np.float64)
        if prob.ndim != 2:
            raise ValueError(f"Grid.prob must be 2-D, got shape {prob.shape}")
        origin = np.asarray(self.origin, dtype=np.float64).reshape(-1)
        if origin.shape == (2,):
            origin = np.array([origin[0], origin[1], 0.0])
        if origin.shape != (3,):
            raise ValueError(f"Grid.origin must be (x, y[, yaw]), got shape {origin.shape}")
        if not (self.resolution > 0):
            raise ValueError(f"Grid.resolution must be positive, got {self.resolution}")
        object.__setattr__(self, "prob", prob)
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "resolution", float(self.resolution))

    # --- shape -------------------------------------------------------------------------
    @property
    def rows(self) -> int:
        return self.prob.shape[0]

    @property
    def cols(self) -> int:
        return self.prob.shape[1]

    @property
    def shape(self) -> tuple[int, int]:
        return self.prob.shape

    @property
    def width_m(self) -> float:
        return self.cols * self.resolution

    @property
    def height_m(self) -> float:
        return self.rows * self.resolution

    @property
    def meta(self) -> np.ndarray:
        """(5,) float64 [ox, oy, resolution, rows, cols] for numba kernels (origin yaw must be 0)."""
        return np.array([self.origin[0], self.origin[1], self.resolution, self.rows, self.cols])

    # --- classification ----------------------------------------------------------------
    def occupied(self, thresh: float = OCCUPIED_THRESH) -> np.ndarray:
        """(rows, cols) bool, p >= thresh (unknown is not occupied)."""
        with np.errstate(invalid="ignore"):
            return self.prob >= thresh

    def free(self, thresh: float = FREE_THRESH) -> np.ndarray:
        """(rows, cols) bool, p <= thresh (unknown is not free)."""
        with np.errstate(invalid="ignore"):
            return self.prob <= thresh

    def known(self) -> np.ndarray:
        """(rows, cols) bool, not NaN."""
        return ~np.isnan(self.prob)

    # --- coordinates -------------------------------------------------------------------
    def _rot(self) -> tuple[float, float]:
        return float(np.cos(self.origin[2])), float(np.sin(self.origin[2]))

    def world_to_map(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2) world x, y -> (N, 2) continuous map coordinates (col, row) in cells.

        Cell (r, c) covers [c, c+1) x [r, r+1) in these coordinates; its centre is c+0.5, r+0.5.
        """
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        c, s = self._rot()
        dx = xy[:, 0] - self.origin[0]
        dy = xy[:, 1] - self.origin[1]
        u = (c * dx + s * dy) / self.resolution
        v = (-s * dx + c * dy) / self.resolution
        return np.stack([u, v], axis=1)

    def world_to_cell(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 2) world x, y -> (rows, cols) integer indices (may lie outside the grid)."""
        m = self.world_to_map(xy)
        return np.floor(m[:, 1]).astype(np.int64), np.floor(m[:, 0]).astype(np.int64)

    def cell_to_world(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Cell indices -> (N, 2) world x, y of the cell centres."""
        u = (np.asarray(cols, dtype=np.float64).reshape(-1) + 0.5) * self.resolution
        v = (np.asarray(rows, dtype=np.float64).reshape(-1) + 0.5) * self.resolution
        c, s = self._rot()
        x = self.origin[0] + c * u - s * v
        y = self.origin[1] + s * u + c * v
        return np.stack([x, y], axis=1)

    def in_bounds(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Bool mask of indices inside the grid."""
        rows = np.asarray(rows)
        cols = np.asarray(cols)
        return (rows >= 0) & (rows < self.rows) & (cols >= 0) & (cols < self.cols)

    def occupied_xy(self, thresh: float = OCCUPIED_THRESH) -> np.ndarray:
        """(N, 2) world x, y of the centres of occupied cells."""
        r, c = np.nonzero(self.occupied(thresh))
        return self.cell_to_world(r, c)

    def extent(self) -> tuple[float, float, float, float]:
        """(left, right, bottom, top) in world metres for imshow(origin='lower'); yaw ignored."""
        x0, y0 = self.origin[0], self.origin[1]
        return (x0, x0 + self.width_m, y0, y0 + self.height_m)

    def with_prob(self, prob: np.ndarray) -> "Grid":
        """A grid with the same geometry and new probabilities."""
        return Grid(prob, self.resolution, self.origin.copy())

    def equals(self, other: "Grid") -> bool:
        """Same shape, resolution, origin and probabilities (NaN equal to NaN)."""
        return (self.shape == other.shape and self.resolution == other.resolution
                and np.array_equal(self.origin, other.origin)
                and np.array_equal(self.prob, other.prob, equal_nan=True))
