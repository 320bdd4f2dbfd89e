"""Lidar ray casting against wall segments: a numba kernel and a plain numpy reference.

cast_rays: compiled (also runs as plain Python with NUMBA_DISABLE_JIT=1);
cast_rays_ref: an independent vectorised numpy statement of the same thing, for tests.
Each ray has its own origin, so the beams of one revolution can be cast from the
lidar pose at each beam's own time (motion distortion).
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["cast_rays", "cast_rays_ref"]

# a ray parallel to a segment (|cross| below this) cannot hit it at a single point
_PARALLEL_EPS = 1e-12


@njit(cache=True, nogil=True)
def cast_rays(segments, origins, angles, max_range):
    """Distance from each origin along its angle to the nearest segment.

    segments: (S, 4) x0, y0, x1, y1 (m); origins: (B, 2) m; angles: (B,) world frame, rad;
    max_range: m. Returns (B,) distances in m, inf where no segment lies within max_range.
    """
    n = origins.shape[0]
    out = np.empty(n)
    for b in range(n):
        ox = origins[b, 0]
        oy = origins[b, 1]
        dx = np.cos(angles[b])
        dy = np.sin(angles[b])
        best = np.inf
        for s in range(segments.shape[0]):
            ax = segments[s, 0]
            ay = segments[s, 1]
            ex = segments[s, 2] - ax
            ey = segments[s, 3] - ay
            denom = dx * ey - dy * ex
            if abs(denom) < _PARALLEL_EPS:
                continue
            wx = ax - ox
            wy = ay - oy
            t = (wx * ey - wy * ex) / denom   # distance along the ray
            u = (wx * dy - wy * dx) / denom   # position along the segment, 0..1
            if t >= 0.0 and u >= 0.0 and u <= 1.0 and t < best:
                best = t
        out[b] = best if best <= max_range else np.inf
    return out


def cast_rays_ref(segments: np.ndarray, origins: np.ndarray, angles: np.ndarray,
                  max_range: float) -> np.ndarray:
    """Reference for cast_rays (same arguments and result): a dense (B, S) numpy solve of
    origin + t * d = a + u * e by Cramer's rule over every ray-segment pair."""
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    org = np.asarray(origins, dtype=np.float64).reshape(-1, 2)
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)          # (B, 2)
    a = seg[:, :2]
    e = seg[:, 2:] - a                                              # (S, 2)
    w = a[None, :, :] - org[:, None, :]                             # (B, S, 2)
    # 2x2 system [d, -e] [t, u]^T = w
    det = -d[:, None, 0] * e[None, :, 1] + d[:, None, 1] * e[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (-w[..., 0] * e[None, :, 1] + w[..., 1] * e[None, :, 0]) / det
        u = (d[:, None, 0] * w[..., 1] - d[:, None, 1] * w[..., 0]) / det
    ok = (np.abs(det) >= _PARALLEL_EPS) & (t >= 0) & (u >= 0) & (u <= 1)
    dist = np.where(ok, t, np.inf).min(axis=1) if seg.shape[0] else np.full(len(org), np.inf)
    return np.where(dist <= max_range, dist, np.inf)
