"""`graph`: pose-graph SLAM, the Cartographer family (docs/algorithms/graph.md): local SLAM
with submaps, branch-and-bound loop closure, sparse pose adjustment."""
from slam.graph.config import GraphConfig
from slam.graph.slam import GraphSlam

__all__ = ["GraphSlam", "GraphConfig"]
