"""Pure-pursuit route following (Coulter 1992) with a ramped forward speed.

The path is the start position followed by the route waypoints. Each control step the
robot aims at the point `lookahead` metres of arc length ahead of its progress along
the path, with curvature 2 sin(alpha) / L. The forward speed ramps up at `accel`, is
lowered so the turn rate stays <= max_turn_rate (0.7 rad/s in the reference study) and
to brake within the distance left along the route, and drops to zero for a turn in place
when the heading error exceeds `turn_in_place`. Progress only moves forward (within a
window), so a path that passes near itself (a spiral), revisits a waypoint or ends where
it starts (a closed route) is followed in order.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ControllerConfig", "PurePursuit"]


@dataclass(frozen=True)
class ControllerConfig:
    lookahead: float = 0.35        # m
    max_linear: float = 0.22       # m/s
    max_turn_rate: float = 0.7     # rad/s (reference study)
    accel: float = 0.1             # m/s^2, forward-speed ramp
    decel: float = 0.3             # m/s^2, braking (and for the final approach)
    turn_in_place: float = 1.0     # rad heading error above which the robot turns on the spot
    turn_gain: float = 1.5         # 1/s, turn rate per rad of heading error when turning in place
    goal_tolerance: float = 0.05   # m
    stuck_timeout: float = 20.0    # s without 5 cm of progress ends the run
    search_window: float = 1.0     # m of arc length ahead searched for the closest point

    def __post_init__(self):
        for n in ("lookahead", "max_linear", "max_turn_rate", "accel", "decel", "turn_gain",
                  "goal_tolerance", "stuck_timeout", "search_window"):
            if getattr(self, n) <= 0:
                raise ValueError(f"{n} must be > 0")


class PurePursuit:
    """command(x, y, yaw, t, dt) -> (v, w); `done` once the end is reached or stuck
    (`stuck` tells which)."""

    def __init__(self, path_xy: np.ndarray, cfg: ControllerConfig):
        path = np.asarray(path_xy, dtype=np.float64).reshape(-1, 2)
        keep = np.ones(len(path), bool)
        keep[1:] = np.linalg.norm(np.diff(path, axis=0), axis=1) > 1e-9
        path = path[keep]
        if len(path) == 0:
            raise ValueError("an empty path")
        if len(path) == 1:       # nowhere to go: a path of zero length, done at once
            path = np.vstack([path, path + [1e-6, 0.0]])
        self.cfg = cfg
        self.path = path
        seg = np.diff(path, axis=0)
        self.seg_len = np.linalg.norm(seg, axis=1)
        self.cum = np.concatenate([[0.0], np.cumsum(self.seg_len)])
        self.length = float(self.cum[-1])
        self._cum = self.cum.tolist()
        self._seg = [(float(p[0]), float(p[1]), float(d[0]), float(d[1]), float(n))
                     for p, d, n in zip(path[:-1], seg, self.seg_len)]
        self._end = (float(path[-1, 0]), float(path[-1, 1]))
        self.s = 0.0            # progress (arc length of the closest point)
        self.v = 0.0
        self.done = self.length < 1e-3
        self.stuck = False
        self._best_s = 0.0
        self._best_t = 0.0

    def _segment_at(self, s: float) -> int:
        i = bisect.bisect_right(self._cum, s) - 1
        last = len(self._seg) - 1
        return 0 if i < 0 else (last if i > last else i)

    def _point_at(self, s: float) -> tuple[float, float]:
        s = 0.0 if s < 0.0 else (self.length if s > self.length else s)
        i = self._segment_at(s)
        x0, y0, dx, dy, length = self._seg[i]
        f = (s - self._cum[i]) / length
        return x0 + f * dx, y0 + f * dy

    def _progress(self, x: float, y: float) -> float:
        """Arc length of the closest path point within [s, s + search_window]."""
        s_lo = self.s
        s_hi = self.s + self.cfg.search_window
        best_d2, best_s = math.inf, s_lo
        # plain Python: the window holds a few segments, numpy's call overhead would dominate
        for i in range(self._segment_at(s_lo), self._segment_at(s_hi) + 1):
            x0, y0, dx, dy, length = self._seg[i]
            f = ((x - x0) * dx + (y - y0) * dy) / (length * length)
            f = 0.0 if f < 0.0 else (1.0 if f > 1.0 else f)
            s_c = self._cum[i] + f * length
            if s_c < s_lo:       # the closest point lies behind the progress: clamp to it
                s_c = s_lo
                f = (s_c - self._cum[i]) / length
            elif s_c > s_hi:
                s_c = s_hi
                f = (s_c - self._cum[i]) / length
            d2 = (x0 + f * dx - x) ** 2 + (y0 + f * dy - y) ** 2
            if d2 < best_d2:
                best_d2, best_s = d2, s_c
        return best_s

    def command(self, x: float, y: float, yaw: float, t: float, dt: float) -> tuple[float, float]:
        """Twist (v m/s, w rad/s) for the robot at (x, y, yaw) at time t; dt: control period."""
        cfg = self.cfg
        if self.done:
            self.v = 0.0
            return 0.0, 0.0
        self.s = self._progress(x, y)
        if self.s > self._best_s + 0.05:
            self._best_s, self._best_t = self.s, t
        elif t - self._best_t > cfg.stuck_timeout:
            self.done = self.stuck = True
            self.v = 0.0
            return 0.0, 0.0
        end_x, end_y = self._end
        to_end = math.hypot(end_x - x, end_y - y)
        remaining = self.length - self.s
        if remaining < cfg.lookahead and to_end < cfg.goal_tolerance:
            self.done = True
            self.v = 0.0
            return 0.0, 0.0
        tx, ty = self._point_at(self.s + cfg.lookahead)
        dx, dy = tx - x, ty - y
        dist = math.hypot(dx, dy)
        alpha = math.atan2(dy, dx) - yaw
        alpha = math.atan2(math.sin(alpha), math.cos(alpha))
        if abs(alpha) > cfg.turn_in_place:
            # brake first, then turn on the spot
            self.v = max(0.0, self.v - cfg.decel * dt)
            w = max(-cfg.max_turn_rate, min(cfg.max_turn_rate, cfg.turn_gain * alpha))
            return self.v, (w if self.v == 0.0 else 0.0)
        curvature = 2.0 * math.sin(alpha) / max(dist, 1e-6)
        v_target = cfg.max_linear
        if abs(curvature) > 1e-9:
            v_target = min(v_target, cfg.max_turn_rate / abs(curvature))
        # stop at the end of the route: v <= sqrt(2 a d), d the distance left along the route
        # (a closed route ends where it starts: the straight line to its end is no guide);
        # off the path near the end, the straight line is the longer and the one to cover
        v_target = min(v_target, math.sqrt(2.0 * cfg.decel * max(remaining, to_end)))
        if v_target > self.v:
            self.v = min(v_target, self.v + cfg.accel * dt)
        else:
            self.v = max(v_target, self.v - cfg.decel * dt)
        w = self.v * curvature
        if self.v < 0.02 and abs(alpha) > 0.1:
            # too slow for pure pursuit to turn: rotate towards the target meanwhile
            w = cfg.turn_gain * alpha
        w = max(-cfg.max_turn_rate, min(cfg.max_turn_rate, w))
        return self.v, w
