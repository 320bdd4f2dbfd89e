"""`pf`: Rao-Blackwellized particle filter SLAM, the Gmapping family (docs/algorithms/pf.md)."""
from slam.pf.config import PfConfig
from slam.pf.slam import ParticleFilterSlam

__all__ = ["ParticleFilterSlam", "PfConfig"]
