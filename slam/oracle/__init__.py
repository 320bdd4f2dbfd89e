"""The oracle: the output map built at the true poses, the benchmark's ceiling."""
from slam.oracle.config import OracleConfig
from slam.oracle.slam import OracleSlam

__all__ = ["OracleSlam", "OracleConfig"]
