"""pf's config values that follow from the log's sensors (ParticleFilterSlam.derive_config).

Each rule gives the TurtleBot3 values of PfConfig on an LDS-01 log (360 beams, 3.5 m,
+-5 % noise), so those logs run on the class defaults; on another lidar it gives what
GMapping's own parameters mean for that sensor. A log without a gyro is run on its wheel
odometry with GMapping's motion noise.

The 0.025 m cells were chosen on LDS-01 logs (docs/algorithms/pf.md). A lidar that reaches
farther keeps GMapping's 0.05 m: ray tracing and map memory grow with range / delta, and the
finer grid has not been measured on such logs.
"""
from __future__ import annotations

from slam.pf.config import GMAPPING_MOTION, PfConfig
from slam.sensors import REFERENCE_RATE, Derived, SensorFacts, noise_smoothing_beams

__all__ = ["derive_pf_config", "MATCHED_BEAMS", "FINE_GRID_MAX_RANGE"]

# beams a scan is matched with: the LDS-01's 360 (GMapping's lskip thins denser scanners)
MATCHED_BEAMS = 360
# m: lidars reaching no farther map on PfConfig's 0.025 m cells, the others on GMapping's 0.05 m
FINE_GRID_MAX_RANGE = 4.0
# GMapping's delta (m) and the refinement's pull to the prior that goes with it
GMAPPING_DELTA = 0.05
GMAPPING_DELTA_PRIOR_WEIGHT = 3.0


def derive_pf_config(s: SensorFacts) -> list[Derived]:
    """pf's sensor-dependent values from `s`."""
    out = [Derived("max_urange", s.range_max,
                   "the sensor's range limit: every return is used (GMapping's maxUrange)")]
    delta = PfConfig.delta
    if s.range_max > FINE_GRID_MAX_RANGE:
        delta = GMAPPING_DELTA
        out.append(Derived("delta", delta,
                           f"GMapping's {delta:g} m cells: the range reaches past "
                           f"{FINE_GRID_MAX_RANGE:g} m, where the finer cells were not chosen"))
        out.append(Derived("matcher.gn_prior_weight", GMAPPING_DELTA_PRIOR_WEIGHT,
                           f"the pull to the motion prior that goes with {delta:g} m cells"))
    extent = max(50.0, 1.25 * s.range_max)
    out.append(Derived("map_extent", extent,
                       "50 m, or 1.25 x the range limit when larger, so a scan taken near the "
                       "map's edge stays on it"))
    out.append(Derived("smooth_beams", noise_smoothing_beams(s, delta),
                       f"neighbouring beams averaged until the range noise at 2 m is a quarter "
                       f"cell ({delta / 4:g} m), at most 4"))
    out.append(Derived("matcher.lskip", max(0, round(s.beams / MATCHED_BEAMS) - 1),
                       f"match about {MATCHED_BEAMS} beams a scan: every (lskip+1)-th of "
                       f"{s.beams}"))
    out.append(Derived("throttle_scans", max(1, round(s.scan_rate / REFERENCE_RATE)),
                       f"take every n-th scan, n the scan rate ({s.scan_rate:.1f} Hz) over "
                       f"{REFERENCE_RATE:g} Hz: the motion noise, drawn per scan taken, was set "
                       "for that rate"))
    if not s.imu:
        out.append(Derived("odometry_heading", "wheels",
                           "no gyro in the log: the odometry turns by its wheels"))
        out += [Derived(f"motion.{k}", v, "GMapping's noise for odometry that turns by its wheels")
                for k, v in GMAPPING_MOTION.items()]
    return out
