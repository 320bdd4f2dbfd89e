"""PfConfig: the options of the Gmapping-family SLAM. Comments name the GMapping parameter a
field is; defaults are ROS gmapping's, the update thresholds and ranges TurtleBot3's
gmapping_params.yaml (a 3.5 m lidar in small worlds), except where marked "not in Gmapping"
(docs/algorithms/pf.md lists them with their effect)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slam.output_map import OutputMapConfig
from slam.pf._match_kernel import make_params
from slam.pf.odometry import HEADINGS

__all__ = ["MotionConfig", "MatcherConfig", "PfConfig", "GMAPPING_MOTION"]

# GMapping's motion noise, for odometry that turns by its wheels
GMAPPING_MOTION = {"srr": 0.1, "srt": 0.2, "str": 0.1, "stt": 0.2}


@dataclass(frozen=True)
class MotionConfig:
    """Odometry noise, standard deviations proportional to the motion (Gmapping's model). The
    defaults are for the TurtleBot3's odometry, the gyro's heading with the wheels' distance
    (GMapping's, for wheel odometry: GMAPPING_MOTION; a log without a gyro gets them)."""

    srr: float = 0.03  # srr: translation error (m) per metre translated (GMapping 0.1)
    srt: float = 0.02  # srt: rotation error (rad) per metre translated (GMapping 0.2)
    str: float = 0.02  # str: translation error (m) per radian rotated (GMapping 0.1)
    stt: float = 0.02  # stt: rotation error (rad) per radian rotated (GMapping 0.2)
    # floor of the motion prior's standard deviations (m, m, rad) in the proposal, so a
    # particle that barely moved still has a proper prior density
    prior_min_std: tuple[float, float, float] = (0.005, 0.005, 0.005)


@dataclass(frozen=True)
class MatcherConfig:
    """Gmapping's scan matcher and likelihood, and the Gauss-Newton refinement."""

    sigma: float = 0.05          # sigma: m^2, score of a beam = exp(-d^2 / sigma)
    kernel_size: int = 1         # kernelSize: search window half-width (cells) around each end point
    lstep: float = 0.05          # lstep: initial linear step of the hill climbing (m)
    astep: float = 0.05          # astep: initial angular step (rad)
    iterations: int = 5          # iterations: step halvings of the hill climbing
    lsigma: float = 0.075        # lsigma: m^2, beam log-likelihood = -d^2 / lsigma
    null_likelihood: float = -0.5  # nullLikelihood: unmatched beam = this / lsigma
    # fullnessThreshold (GMapping 0.1): a cell is occupied for matching above this n / visits;
    # with the range noise spreading a wall's returns over a band of cells, 0.1 latches onto
    # the band's front edge
    fullness: float = 0.3
    ogain: float = 3.0           # ogain: weights smoothed as exp(log w / (ogain * particles))
    lskip: int = 0               # lskip: use every (lskip+1)-th beam for matching
    minimum_score: float = 50.0  # minimumScore (TurtleBot3): below it the match is ignored
    # the proposal grid around the matched pose (GMapping: 0.01 m and 0.005 rad); here the hill
    # climb's last step, lstep / 2^iterations: the likelihood is lumpy at the centimetre scale
    llsamplerange: float = 0.0015625  # llsamplerange: proposal grid half-width in x and y (m)
    llsamplestep: float = 0.0015625   # llsamplestep: proposal grid step in x and y (m)
    lasamplerange: float = 0.0015625  # lasamplerange: proposal grid half-width in yaw (rad)
    lasamplestep: float = 0.0015625   # lasamplestep: proposal grid step in yaw (rad)
    # not in Gmapping: Gauss-Newton steps from the hill climb's pose on the point-to-line
    # distances to the walls of the particle's mean hit points; their information is the
    # proposal's covariance (0 = the hill climb alone, the sampled covariance)
    gn_iterations: int = 5
    gn_max_angle_step: float = 0.2  # rad, clamp of one step's rotation (Hector's)
    # pull towards the motion prior's mean: cost per squared prior standard deviation (the
    # log's defaults set 3 where they set 0.05 m cells)
    gn_prior_weight: float = 6.0

    def params(self) -> np.ndarray:
        """The kernels' params array (slam/pf/_match_kernel.py)."""
        return make_params(sigma=self.sigma, lsigma=self.lsigma,
                           null_likelihood=self.null_likelihood, fullness=self.fullness,
                           kernel=self.kernel_size, lstep=self.lstep, astep=self.astep,
                           iterations=self.iterations, llsamplerange=self.llsamplerange,
                           llsamplestep=self.llsamplestep, lasamplerange=self.lasamplerange,
                           lasamplestep=self.lasamplestep)


@dataclass(frozen=True)
class PfConfig:
    """Particle-filter SLAM (Gmapping)."""

    particles: int = 30               # particles
    throttle_scans: int = 1           # throttle_scans (GMapping's ROS node): the filter takes
                                      # every n-th scan; the motion noise is drawn per scan taken
    resample_threshold: float = 0.5   # resampleThreshold: resample when Neff < this * particles
    linear_update: float = 0.2        # linearUpdate (m): filter update after this much travel
    angular_update: float = 0.2       # angularUpdate (rad): ... or after this much rotation
    max_urange: float = 3.5           # maxUrange (m): beams are cropped here (TurtleBot3: 3.0)
    max_range: float = 0.0            # maxRange (m): readings at/after it are no return (0: sensor's)
    # delta: map resolution (m); the log's defaults set GMapping's 0.05 for lidars that reach
    # past 4 m (slam.pf.defaults)
    delta: float = 0.025
    map_extent: float = 50.0          # xmin/xmax/ymin/ymax: half side (m) of the square map around the start
    tile: int = 16                    # cells per side of a copy-on-write map tile (a power of two)
    smooth_beams: int = 4             # not in Gmapping: each return is the mean point of 2k+1 neighbouring beams
    # not in Gmapping: the odometry's heading, "imu": the gyro's turn with the wheels' distance,
    # as the TurtleBot3's odometry reports it (turtlebot3_node, use_imu); "wheels": as logged
    # (then set motion to GMapping's srr 0.1, srt 0.2, str 0.1, stt 0.2, as a log without a
    # gyro gets them)
    odometry_heading: str = "imu"
    motion: MotionConfig = field(default_factory=MotionConfig)
    matcher: MatcherConfig = field(default_factory=MatcherConfig)
    output_map: OutputMapConfig = field(default_factory=OutputMapConfig)

    def __post_init__(self):
        if self.particles < 1:
            raise ValueError(f"particles must be >= 1, got {self.particles}")
        if self.throttle_scans < 1:
            raise ValueError(f"throttle_scans must be >= 1, got {self.throttle_scans}")
        if not 0.0 <= self.resample_threshold <= 1.0:
            raise ValueError(f"resample_threshold must lie in [0, 1], got {self.resample_threshold}")
        for name in ("max_urange", "delta", "map_extent"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.tile < 1 or self.tile & (self.tile - 1):
            raise ValueError(f"tile must be a power of two, got {self.tile}")
        if self.smooth_beams < 0:
            raise ValueError(f"smooth_beams must be >= 0, got {self.smooth_beams}")
        if self.odometry_heading not in HEADINGS:
            raise ValueError(f"odometry_heading must be one of {', '.join(HEADINGS)}, "
                             f"got {self.odometry_heading!r}")
        m = self.matcher
        if m.gn_iterations < 0 or m.gn_prior_weight < 0:
            raise ValueError("matcher: need gn_iterations >= 0 and gn_prior_weight >= 0")
