"""Pose-graph SLAM `graph` (Cartographer family): local SLAM with submaps, branch-and-bound
loop closure, sparse pose adjustment. Importing this package registers the algorithm."""
from slam.graph.config import GraphConfig
from slam.graph.graph_slam import GraphSlam

__all__ = ["GraphSlam", "GraphConfig"]
