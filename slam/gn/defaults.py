"""gn's config values that follow from the log's sensors (GaussNewtonSlam.derive_config).

Each rule gives GnConfig's defaults on a simulated LDS-01 log (IMU, 360 beams, +-5 % noise).
"""
from __future__ import annotations

from slam.sensors import Derived, SensorFacts, noise_smoothing_beams

__all__ = ["derive_gn_config"]


def derive_gn_config(s: SensorFacts, resolution: float = 0.05) -> list[Derived]:
    """gn's sensor-dependent values from `s` (resolution: the finest map level's cell, m)."""
    return [
        Derived("use_imu", bool(s.imu), "the gyro predicts the rotation when the log has an IMU"),
        Derived("preprocess.smooth_beams", noise_smoothing_beams(s, resolution),
                f"neighbouring beams averaged until the range noise at 2 m is a quarter cell "
                f"({resolution / 4:g} m), at most 4"),
    ]
