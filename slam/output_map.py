"""The output map: the map every algorithm writes, built the same way by all of them.

Each scan is taken at the pose the algorithm estimated for it (the oracle: the true pose),
de-skewed with the motion during its revolution. When the map is asked for, every hit of
every scan, up to the sensor's range, goes into one surface estimate
(slam/_kernels/surface_map.py):
1. each hit is weighted by 1 / sigma^2, sigma from the sensor's range noise model
   (Scan.range_noise) at the mean range of its neighbouring beams;
2. each hit is moved onto the local surface by mean shift along the local normal: a wide
   pass (a window of 2 * wide_radius + 1 cells), then a fine one (2 * fine_radius + 1) over
   the moved hits, each reading only the hits seen from the same side of the surface;
3. a cell is occupied when it holds at least `min_hits` moved hits whose weight is at least
   `peak_share` of the best cell around it, so a wall is drawn in the cell that holds its
   surface, one cell thick;
4. the rays free the cells they cross up to `free_margin_sigmas` sigma short of their hit
   (no-return beams up to preprocess.free_range); a cell's probability falls with the number
   of scans that freed it (p_free per scan, log-odds clamped at l_min).
Near hits, with the smallest sigma, decide where a wall is; walls seen only from afar are still
mapped. Nothing but the scans, their poses and the sensor's noise model goes in, so the maps
of two algorithms differ only where their poses differ, and the oracle's map is the ceiling
of exactly this map building.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from worlds.grid import Grid
from worlds.limits import check_grid_cells
from slam._kernels import surface_map as K
from slam.base import Scan
from slam.occupancy import GridConfig, logodds
from slam.preprocess import PreprocessConfig, preprocess, twist_from_poses
from slam.range_noise import RangeNoise

__all__ = ["OutputMapConfig", "OutputGridConfig", "OutputPreprocessConfig", "SurfaceConfig",
           "OutputMap", "output_map_from_trajectory", "build_output_map"]


@dataclass(frozen=True)
class OutputGridConfig(GridConfig):
    """GridConfig with the output map's defaults (a YAML block keeps those it does not name).
    p_free: the update of a cell per scan whose rays freed it; p_occupied: the probability of
    a surface cell."""

    p_free: float = 0.4        # update of a cell per scan whose rays freed it
    p_occupied: float = 0.9    # probability a surface cell is drawn with


@dataclass(frozen=True)
class OutputPreprocessConfig(PreprocessConfig):
    """PreprocessConfig with the output map's defaults: every hit up to the sensor's range,
    no smoothing (the surface estimate averages along the wall itself)."""

    free_range: float = 2.0    # m; no-return beams mark free space up to 2 m


@dataclass(frozen=True)
class SurfaceConfig:
    """How hits become surface cells (slam/_kernels/surface_map.py)."""

    neighbours: int = 2             # beams on each side whose mean range the noise model is read at
    neighbour_jump: float = 0.1     # ... those within this fraction of the beam's range
    normal_beams: int = 3           # beams on each side a hit's normal is fitted to ...
    normal_gate: float = 0.25       # ... those within this distance of it (m)
    wide_radius: int = 2            # cells: the first mean-shift pass's window is 2 r + 1 wide
    fine_radius: int = 1            # cells: the second pass's window
    wide_spread: int = 1            # normal sectors (of 16) on each side a hit reads in the first pass
    fine_spread: int = 0            # ... in the second
    iterations: int = 4             # projections per hit and pass at most
    min_hits: int = 3               # moved hits a surface cell holds at least
    peak_share: float = 0.25        # ... with a weight at least this share of its 3 x 3 best
    free_margin_sigmas: float = 2.0  # rays free cells up to this many sigma short of the hit

    def __post_init__(self):
        for name in ("neighbours", "wide_radius", "fine_radius", "iterations", "min_hits"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if not 0.0 <= self.peak_share <= 1.0:
            raise ValueError(f"peak_share must be in [0, 1], got {self.peak_share}")
        if self.neighbour_jump < 0 or self.free_margin_sigmas < 0:
            raise ValueError("neighbour_jump and free_margin_sigmas must be >= 0")


@dataclass(frozen=True)
class OutputMapConfig:
    """How the output map is built: grid values, scan preprocessing, the surface estimate and
    the range noise model (None: each scan's own, i.e. the log's)."""

    grid: OutputGridConfig = field(default_factory=OutputGridConfig)
    preprocess: OutputPreprocessConfig = field(default_factory=OutputPreprocessConfig)
    surface: SurfaceConfig = field(default_factory=SurfaceConfig)
    range_noise: RangeNoise | None = None   # the lidar's range error model; None: the log's


class OutputMap:
    """Collects scans at given poses; `to_grid()` builds the map from all of them."""

    def __init__(self, cfg: OutputMapConfig, center=(0.0, 0.0)):
        self.cfg = cfg
        self.center = tuple(float(v) for v in center[:2])
        self._poses: list[np.ndarray] = []      # (3,) robot pose per scan
        self._lidar: list[np.ndarray] = []      # (2,) lidar position in the robot frame per scan
        self._hits: list[np.ndarray] = []       # (N, 2) hit points per scan, robot frame
        self._misses: list[np.ndarray] = []     # (M, 2) free-range points per scan, robot frame
        self._noise: RangeNoise | None = cfg.range_noise
        self.scans = 0

    def insert(self, scan: Scan, pose: np.ndarray, twist: np.ndarray | None = None) -> None:
        """Add `scan` taken at robot pose (3,) with the robot moving at twist (3,) (or None)."""
        if self._noise is None:
            self._noise = scan.range_noise
        pts = preprocess(scan, self.cfg.preprocess, twist)
        self._poses.append(np.asarray(pose, dtype=np.float64).reshape(3))
        self._lidar.append(pts.origin)
        self._hits.append(pts.points)
        self._misses.append(pts.misses)
        self.scans += 1

    def to_grid(self) -> Grid:
        """The map as a Grid (probabilities, NaN unknown) covering the observed cells."""
        noise = self._noise if self._noise is not None else RangeNoise()
        poses = np.array(self._poses, dtype=np.float64).reshape(-1, 3)
        lidar = np.array(self._lidar, dtype=np.float64).reshape(-1, 2)
        hits, hit_scan = _stacked(self._hits)
        misses, miss_scan = _stacked(self._misses)
        ranges = np.hypot(*(hits - lidar[hit_scan]).T)
        return build_output_map(self.cfg, noise, _to_world(poses, lidar, np.arange(len(poses))),
                                _to_world(poses, hits, hit_scan), ranges, hit_scan,
                                _to_world(poses, misses, miss_scan), miss_scan, self.center)


def _stacked(per_scan: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(K, 2) the points of every scan, (K,) the index of the scan of each."""
    counts = np.array([len(p) for p in per_scan], dtype=np.int64)
    if not counts.sum():
        return np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
    return np.concatenate(per_scan).reshape(-1, 2), np.repeat(np.arange(len(per_scan)), counts)


def _to_world(poses: np.ndarray, xy: np.ndarray, scan: np.ndarray) -> np.ndarray:
    """(K, 2) points xy (K, 2) of robot frames poses[scan] in the world frame."""
    p = poses[scan]
    c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
    return np.stack([p[:, 0] + c * xy[:, 0] - s * xy[:, 1], p[:, 1] + s * xy[:, 0] + c * xy[:, 1]],
                    axis=1)


def _lattice(res: float, points: list[np.ndarray], center) -> tuple[float, float, int, int]:
    """(ox, oy, rows, cols) of a grid on the global lattice (multiples of res) holding every
    point with a margin of 4 cells."""
    allp = [p.reshape(-1, 2) for p in points if len(p)]
    if not allp:
        allp = [np.asarray(center, dtype=np.float64).reshape(1, 2)]
    stacked = np.vstack(allp)
    lo = np.floor(stacked.min(axis=0) / res) - 4
    hi = np.floor(stacked.max(axis=0) / res) + 5
    rows, cols = int(hi[1] - lo[1]), int(hi[0] - lo[0])
    check_grid_cells(rows, cols, "output map", "the scans' points (a pose far off)")
    return float(lo[0] * res), float(lo[1] * res), rows, cols


def build_output_map(cfg: OutputMapConfig, noise: RangeNoise, origins, hits, ranges, hit_scan,
                     misses, miss_scan, center=(0.0, 0.0)) -> Grid:
    """The output map of S scans: world lidar positions origins (S, 2) m, hit points (N, 2) m
    with their ranges (N,) m and scan indices hit_scan (N,) (non-decreasing), free-range points
    of no-return beams (M, 2) m with scan indices miss_scan (M,), read with the range noise
    model `noise`."""
    res, sc = cfg.grid.resolution, cfg.surface
    ox, oy, rows, cols = _lattice(res, [origins, hits, misses], center)
    n_scans = len(origins)
    starts = np.searchsorted(hit_scan, np.arange(n_scans + 1)).astype(np.int64)
    o = np.ascontiguousarray((np.asarray(origins, dtype=np.float64).reshape(-1, 2) - [ox, oy]) / res)
    px = np.ascontiguousarray((hits[:, 0] - ox) / res)
    py = np.ascontiguousarray((hits[:, 1] - oy) / res)

    sigma = K.hit_sigmas(np.ascontiguousarray(ranges, dtype=np.float64), starts,
                         int(sc.neighbours), float(sc.neighbour_jump), noise.as_array())
    w = 1.0 / (sigma * sigma)
    sector = K.hit_normals(px, py, w, starts, int(sc.normal_beams), sc.normal_gate / res,
                           np.ascontiguousarray(o[hit_scan, 0]), np.ascontiguousarray(o[hit_scan, 1]))
    wide = K.project_hits(px, py, px, py, w, sector, int(sc.wide_spread), rows, cols,
                          int(sc.wide_radius), int(sc.iterations))
    wx, wy = np.ascontiguousarray(wide[:, 0]), np.ascontiguousarray(wide[:, 1])
    fine = K.project_hits(wx, wy, wx, wy, w, sector, int(sc.fine_spread), rows, cols,
                          int(sc.fine_radius), int(sc.iterations))
    surface, _ = K.mark_surface(np.ascontiguousarray(fine[:, 0]), np.ascontiguousarray(fine[:, 1]),
                                w, rows, cols, int(sc.min_hits), float(sc.peak_share))

    # free space: each scan's rays, hit rays stopping free_margin_sigmas short, miss rays to
    # their end (the order of a scan's rays does not change what it frees)
    ray_scan = np.concatenate([hit_scan, miss_scan])
    order = np.argsort(ray_scan, kind="stable")
    ends = np.concatenate([np.stack([px, py], axis=1),
                           (np.asarray(misses, dtype=np.float64).reshape(-1, 2) - [ox, oy]) / res])[order]
    margin = np.concatenate([sc.free_margin_sigmas * sigma / res, np.zeros(len(miss_scan))])[order]
    ray_starts = np.searchsorted(ray_scan[order], np.arange(n_scans + 1)).astype(np.int64)
    free, seen = K.carve_free(o, ray_starts, np.ascontiguousarray(ends[:, 0]),
                              np.ascontiguousarray(ends[:, 1]), np.ascontiguousarray(margin),
                              rows, cols)
    prob = np.full((rows, cols), np.nan)
    l_free = np.maximum(free * logodds(cfg.grid.p_free), cfg.grid.l_min)
    prob[seen] = 1.0 / (1.0 + np.exp(-l_free[seen]))
    prob[surface] = cfg.grid.p_occupied
    return Grid(prob, res, np.array([ox, oy, 0.0]))


def output_map_from_trajectory(cfg: OutputMapConfig, scans: list[Scan], times: np.ndarray,
                               poses: np.ndarray) -> Grid:
    """The output map of scans (N) at poses (N, 3) taken at times (N,): each scan de-skewed with
    the motion from its pose to the next (the last one: from the previous to it)."""
    out = OutputMap(cfg, center=tuple(poses[0][:2]))
    for i, scan in enumerate(scans):
        j, k = (i, i + 1) if i + 1 < len(poses) else (i - 1, i)
        twist = twist_from_poses(poses[j], poses[k], times[k] - times[j]) if j >= 0 else np.zeros(3)
        out.insert(scan, poses[i], twist)
    return out.to_grid()
