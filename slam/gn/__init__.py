"""`gn`: Gauss-Newton scan-to-map SLAM, the Hector family (docs/algorithms/gn.md)."""
from slam.gn.config import GnConfig
from slam.gn.slam import GaussNewtonSlam

__all__ = ["GaussNewtonSlam", "GnConfig"]
