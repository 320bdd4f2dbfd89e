"""GnConfig: the options of the Hector-family SLAM (hector_mapping names in brackets).

Defaults are hector_mapping's, for a 5 Hz, 3.5 m lidar, except the options marked "not in
hector" (docs/algorithms/gn.md lists them with their effect).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from slam.output_map import OutputMapConfig
from slam.preprocess import PreprocessConfig

__all__ = ["GnConfig", "MatchPreprocessConfig", "MAP_TYPES"]

MAP_TYPES = ("reflectance_count", "log_odds")


@dataclass(frozen=True)
class MatchPreprocessConfig(PreprocessConfig):
    """PreprocessConfig with gn's matching defaults (a YAML block keeps those it does not name)."""

    smooth_beams: int = 4      # not in hector: mean over 9 neighbouring beams (range noise / 3)


@dataclass(frozen=True)
class GnConfig:
    """Hector SLAM parameters."""

    map_resolution: float = 0.05          # [map_resolution] m, cell size of the finest level
    map_multi_res_levels: int = 3         # [map_multi_res_levels] level k has 2^k x the cell size
    # the matching maps' cells (hector: a compile-time choice): "reflectance_count" =
    # reflections / visits (GridMapReflectanceCount), "log_odds" = hector's default GridMapLogOdds
    map_type: str = "reflectance_count"
    update_factor_free: float = 0.4       # [update_factor_free] log_odds: probability of a freed cell
    update_factor_occupied: float = 0.9   # [update_factor_occupied] log_odds: probability of a hit cell
    map_update_distance_thresh: float = 0.4   # [map_update_distance_thresh] m moved before a map update
    map_update_angle_thresh: float = 0.9      # [map_update_angle_thresh] rad turned before a map update
    iterations_finest: int = 5            # Gauss-Newton steps at the finest level (hector: 5, fixed)
    iterations_coarse: int = 3            # Gauss-Newton steps at every coarser level (hector: 3, fixed)
    max_angle_step: float = 0.2           # rad, clamp of one step's rotation (hector: 0.2, fixed)
    logodds_min: float = -50.0            # log_odds: clamp below (hector: none)
    logodds_max: float = 50.0             # log_odds: clamp above (hector: 50)
    check_prior: bool = True              # not in hector: also match the finest level from the prior, keep the better
    use_imu: bool = True                  # predict the rotation between scans from the gyro
    deskew_velocity_window: float = 1.0   # not in hector: s of estimates whose mean velocity de-skews (0 = rotation only)
    # not in hector: pull of every step towards the gyro-predicted yaw, cost per point per rad^2
    prior_yaw_weight: float = 30.0
    match_unknown: float = 0.0            # value read in never-visited cells (hector: 0.5)
    # not in hector (Zhang, Kaess, Singh, ICRA 2016): a translation direction whose smallest
    # eigenvalue of the scan normals' mean outer product is below the threshold keeps the
    # constant-velocity position, pulled with degeneracy_weight per point per m^2 (0 = off)
    degeneracy_threshold: float = 0.1
    degeneracy_weight: float = 1000.0     # per point per m^2 along the degenerate direction
    gradient_along_normal: bool = True    # not in hector: a point reads the map gradient along its normal
    # not in hector: pull of every step towards the constant-velocity position, per point per m^2
    velocity_prior_weight: float = 30.0
    preprocess: MatchPreprocessConfig = field(default_factory=MatchPreprocessConfig)  # the matched points
    output_map: OutputMapConfig = field(default_factory=OutputMapConfig)

    def __post_init__(self):
        if self.map_resolution <= 0:
            raise ValueError(f"map_resolution must be positive, got {self.map_resolution}")
        if not 1 <= self.map_multi_res_levels <= 8:
            # level 8 has 128x the cell size: 6.4 m cells at the default 0.05 m
            raise ValueError(f"map_multi_res_levels must be from 1 to 8, got {self.map_multi_res_levels}")
        if not 0 < self.update_factor_free < 0.5 < self.update_factor_occupied < 1:
            raise ValueError("need 0 < update_factor_free < 0.5 < update_factor_occupied < 1")
        if self.iterations_finest < 1 or self.iterations_coarse < 0:
            raise ValueError("iterations_finest must be >= 1 and iterations_coarse >= 0")
        if self.prior_yaw_weight < 0:
            raise ValueError(f"prior_yaw_weight must be >= 0, got {self.prior_yaw_weight}")
        if not 0.0 <= self.degeneracy_threshold <= 0.5 or self.degeneracy_weight < 0:
            raise ValueError("need 0 <= degeneracy_threshold <= 0.5 and degeneracy_weight >= 0")
        if self.velocity_prior_weight < 0:
            raise ValueError(f"velocity_prior_weight must be >= 0, got {self.velocity_prior_weight}")
        if not 0.0 <= self.match_unknown <= 1.0:
            raise ValueError(f"match_unknown must lie in [0, 1], got {self.match_unknown}")
        if self.map_type not in MAP_TYPES:
            raise ValueError(f"map_type must be one of {', '.join(MAP_TYPES)}, got {self.map_type!r}")

    @property
    def resolutions(self) -> list[float]:
        """Cell size (m) of each level, finest first."""
        return [self.map_resolution * 2 ** k for k in range(self.map_multi_res_levels)]
