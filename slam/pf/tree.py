"""The trajectory tree of the particle filter: every particle's path as a chain of nodes, so
resampling copies node ids instead of whole trajectories."""
from __future__ import annotations

import numpy as np

__all__ = ["TrajectoryTree"]


class TrajectoryTree:
    """Node i has a pose and a parent (-1: root). Each filter update adds one node per particle."""

    def __init__(self):
        self.poses: list[np.ndarray] = []
        self.parents: list[np.ndarray] = []
        self.n = 0

    def add(self, poses: np.ndarray, parents: np.ndarray) -> np.ndarray:
        """Add one node per pose (N, 3) with the given parents (N,); their ids (N,)."""
        ids = self.n + np.arange(len(poses))
        self.poses.append(np.array(poses, dtype=np.float64))
        self.parents.append(np.array(parents, dtype=np.int64))
        self.n += len(poses)
        return ids

    def chain(self, node: int) -> np.ndarray:
        """(U, 3) poses from the root to `node`."""
        poses = np.concatenate(self.poses)
        parents = np.concatenate(self.parents)
        out = []
        while node >= 0:
            out.append(poses[node])
            node = parents[node]
        return np.array(out[::-1]).reshape(-1, 3)
