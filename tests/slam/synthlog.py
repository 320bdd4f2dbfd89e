"""Synthetic sensor logs for the slam tests: numpy ray casting against wall segments.

A robot drives a given list of waypoints at constant speed (turning on the spot first),
a 360-beam lidar spinning at 5 Hz casts every beam from the pose at its own time, a gyro
reports the true yaw rate at 100 Hz. The same data layout as sim.record writes.
"""
from __future__ import annotations

import numpy as np

from sim.logs import SensorLog

ROOM = 4.0


# wall faces lie on cell centres of the 0.05 m lattice, so the truth raster is unambiguous
SHIFT = 0.025


def box_room_segments(size: float = ROOM, inner: bool = True) -> np.ndarray:
    """(S, 4) wall faces of a square room [0, size]^2 (+SHIFT), with a 0.6 m box at its centre."""
    s = size
    segs = [[0, 0, s, 0], [s, 0, s, s], [s, s, 0, s], [0, s, 0, 0]]
    if inner:
        a, b = s / 2 - 0.3, s / 2 + 0.3
        segs += [[a, a, b, a], [b, a, b, b], [b, b, a, b], [a, b, a, a]]
    return np.array(segs, dtype=np.float64) + SHIFT


def cast(segments: np.ndarray, origin: np.ndarray, dirs: np.ndarray, max_range: float) -> np.ndarray:
    """(B,) distance from origin (2,) along unit dirs (B, 2) to the first segment, inf beyond max_range."""
    p = origin[None, None, :]
    a = segments[None, :, :2]
    e = segments[None, :, 2:] - segments[None, :, :2]
    d = dirs[:, None, :]
    denom = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    ap = a - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ap[..., 0] * e[..., 1] - ap[..., 1] * e[..., 0]) / denom
        u = (ap[..., 0] * d[..., 1] - ap[..., 1] * d[..., 0]) / denom
    ok = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    t = np.where(ok, t, np.inf).min(axis=1)
    t[t > max_range] = np.inf
    return t


def _poses_along(waypoints: np.ndarray, start_yaw: float, v: float, w: float, dt: float):
    """Dense (t, pose) along the waypoints: turn on the spot, then drive straight."""
    poses = [np.array([waypoints[0][0], waypoints[0][1], start_yaw])]
    for wp in waypoints[1:]:
        x, y, th = poses[-1]
        goal = np.arctan2(wp[1] - y, wp[0] - x)
        dth = (goal - th + np.pi) % (2 * np.pi) - np.pi
        for k in range(1, int(np.ceil(abs(dth) / (w * dt))) + 1):
            f = min(1.0, k * w * dt / abs(dth)) if dth != 0 else 1.0
            poses.append(np.array([x, y, th + f * dth]))
        dist = np.hypot(wp[0] - x, wp[1] - y)
        for k in range(1, int(np.ceil(dist / (v * dt))) + 1):
            f = min(1.0, k * v * dt / dist)
            poses.append(np.array([x + f * (wp[0] - x), y + f * (wp[1] - y), goal]))
    poses = np.array(poses)
    poses[:, 2] = np.unwrap(poses[:, 2])
    return np.arange(len(poses)) * dt, poses


def make_log(segments: np.ndarray, waypoints, start_yaw: float = 0.0, seed: int = 0,
             range_sigma: float = 0.01, v: float = 0.2, w: float = 0.8, beams: int = 360,
             scan_period: float = 0.2, range_max: float = 3.5, offset=(-0.032, 0.0, 0.0),
             all_inf: bool = False) -> SensorLog:
    """A SensorLog of a robot driving `waypoints` ((K, 2) m) among `segments` ((S, 4) m)."""
    rng = np.random.default_rng(seed)
    dt = 0.005
    t, poses = _poses_along(np.asarray(waypoints, float), start_yaw, v, w, dt)
    angles = np.linspace(0, 2 * np.pi, beams, endpoint=False)
    t_inc = scan_period / beams
    scan_t = np.arange(0.0, t[-1] - scan_period, scan_period)
    off = np.asarray(offset, float)
    ranges = np.empty((len(scan_t), beams))
    for i, ts in enumerate(scan_t):
        tb = ts + np.arange(beams) * t_inc
        px = np.interp(tb, t, poses[:, 0])
        py = np.interp(tb, t, poses[:, 1])
        th = np.interp(tb, t, poses[:, 2])
        ox = px + np.cos(th) * off[0] - np.sin(th) * off[1]
        oy = py + np.sin(th) * off[0] + np.cos(th) * off[1]
        a = th + off[2] + angles
        dirs = np.stack([np.cos(a), np.sin(a)], axis=1)
        r = np.empty(beams)
        # beams share almost the same origin within a revolution; cast each from its own origin
        for b in range(beams):
            r[b] = cast(segments, np.array([ox[b], oy[b]]), dirs[b:b + 1], range_max)[0]
        r = r + rng.normal(0, range_sigma, beams)
        ranges[i] = np.inf if all_inf else r
    imu_t = np.arange(0.0, t[-1], 0.01)
    yaw_i = np.interp(imu_t, t, poses[:, 2])
    gyro = np.gradient(yaw_i, imu_t)
    gt_pose = poses.copy()
    gt_pose[:, 2] = (gt_pose[:, 2] + np.pi) % (2 * np.pi) - np.pi
    step = 4  # ground truth at 50 Hz
    meta = {"world": "synthetic", "seed": seed, "start_pose": gt_pose[0].tolist(),
            "lidar": {"range_min": 0.12, "range_max": range_max, "offset": off.tolist(),
                      "time_increment": t_inc, "scan_time": scan_period}}
    return SensorLog(scan_t=scan_t, scan_ranges=ranges, scan_angles=angles,
                     odom_t=t[::step], odom_pose=gt_pose[::step], odom_twist=np.zeros((len(t[::step]), 2)),
                     imu_t=imu_t, imu_gyro=gyro, imu_accel=np.zeros((len(imu_t), 2)),
                     imu_yaw=(yaw_i + np.pi) % (2 * np.pi) - np.pi,
                     gt_t=t[::step], gt_pose=gt_pose[::step], meta=meta)


def square_route(size: float = ROOM):
    """A loop around the central box of the room."""
    a, b = 0.9, size - 0.9
    return np.array([[a, a], [b, a], [b, b], [a, b], [a, a]])


def truth_grid(segments: np.ndarray, resolution: float = 0.05, lo=-0.5, hi=ROOM + 0.5):
    """Occupied cells along the segments (1.0), free elsewhere (0.0): a worlds.Grid."""
    from worlds.grid import Grid
    n = int(round((hi - lo) / resolution))
    prob = np.zeros((n, n))
    for x0, y0, x1, y1 in segments:
        k = int(np.ceil(np.hypot(x1 - x0, y1 - y0) / (resolution / 4))) + 1
        xs = np.linspace(x0, x1, k)
        ys = np.linspace(y0, y1, k)
        c = np.floor((xs - lo) / resolution).astype(int)
        r = np.floor((ys - lo) / resolution).astype(int)
        prob[r, c] = 1.0
    return Grid(prob, resolution, np.array([lo, lo, 0.0]))


def score(estimate, truth, thresh: float = 0.65):
    """(precision, sensitivity) of occupied cells, no alignment, no tolerance (same lattice)."""
    occ = estimate.occupied(thresh)
    r, c = np.nonzero(occ)
    xy = estimate.cell_to_world(r, c)
    tr, tc = truth.world_to_cell(xy)
    inside = truth.in_bounds(tr, tc)
    tp_mask = np.zeros(truth.shape, bool)
    tp_mask[tr[inside], tc[inside]] = True
    truth_occ = truth.prob >= 0.5
    tp = int((tp_mask & truth_occ).sum())
    fp = int(occ.sum()) - tp
    fn = int(truth_occ.sum()) - tp
    return tp / max(tp + fp, 1), tp / max(tp + fn, 1)
