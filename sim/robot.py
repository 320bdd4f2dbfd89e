"""A TurtleBot3-Burger-like differential drive in pymunk, driven by wheel speeds.

As in pymunk's tank example: a kinematic control body moves at the twist the wheels
command; the robot body (a disc of the Burger's footprint) is pulled after it by a
PivotJoint and a GearJoint whose forces are limited. Where the robot is blocked by a
wall, or the joints cannot deliver the force, the body lags the command: collisions and
slip make true motion differ from what the wheels turned. Walls and obstacles are static
segments along the edges of World.solid.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk

from worlds.model import World

__all__ = ["RobotConfig", "DiffDriveRobot", "wheel_speeds", "twist_from_wheels"]


@dataclass(frozen=True)
class RobotConfig:
    """TurtleBot3 Burger (ROBOTIS e-Manual, turtlebot3_description burger URDF)."""

    wheel_radius: float = 0.033       # m
    wheel_separation: float = 0.160   # m
    radius: float = 0.105             # m, footprint (collision disc)
    mass: float = 1.0                 # kg (Burger: ~1 kg)
    max_linear: float = 0.22          # m/s
    max_angular: float = 2.84         # rad/s
    encoder_ticks: int = 4096         # per wheel revolution (Dynamixel XL430)
    # joint force limits (N, N*m): enough to drive ~1 kg at the Burger's accelerations,
    # small enough that a wall stops the body instead of being pushed through
    pivot_max_force: float = 20.0
    gear_max_force: float = 5.0
    wall_friction: float = 0.3
    wall_radius: float = 0.002        # m, static segment thickness/2

    def __post_init__(self):
        for n in ("wheel_radius", "wheel_separation", "radius", "mass", "max_linear",
                  "max_angular", "pivot_max_force", "gear_max_force"):
            if getattr(self, n) <= 0:
                raise ValueError(f"{n} must be > 0")
        if self.encoder_ticks < 1:
            raise ValueError("encoder_ticks must be >= 1")

    @property
    def max_wheel_speed(self) -> float:
        """rad/s: the wheel speed of max_linear."""
        return self.max_linear / self.wheel_radius


def wheel_speeds(v: float, w: float, cfg: RobotConfig) -> tuple[float, float]:
    """(left, right) wheel speeds in rad/s for twist v (m/s), w (rad/s), scaled down
    together (keeping the path's curvature) when one exceeds max_wheel_speed."""
    half = 0.5 * cfg.wheel_separation * w
    left = (v - half) / cfg.wheel_radius
    right = (v + half) / cfg.wheel_radius
    top = max(abs(left), abs(right))
    if top > cfg.max_wheel_speed:
        k = cfg.max_wheel_speed / top
        left *= k
        right *= k
    return left, right


def twist_from_wheels(left, right, radius_left, radius_right, separation):
    """(v, w): body twist from wheel speeds (rad/s) and effective radii/separation (m)."""
    vl = left * radius_left
    vr = right * radius_right
    return 0.5 * (vl + vr), (vr - vl) / separation


class DiffDriveRobot:
    """The pymunk space with the static world and the robot.

    drive(v, w, dt, steps, out): physics steps at a commanded body-frame twist;
    pose: (x, y, yaw) of the robot (wheel axle centre).
    """

    def __init__(self, world: World, start: np.ndarray, cfg: RobotConfig):
        self.cfg = cfg
        space = pymunk.Space()
        space.iterations = 10
        static = space.static_body
        for x0, y0, x1, y1 in world.segments:
            seg = pymunk.Segment(static, (float(x0), float(y0)), (float(x1), float(y1)),
                                 cfg.wall_radius)
            seg.friction = cfg.wall_friction
            space.add(seg)
        x, y, yaw = (float(v) for v in start)
        body = pymunk.Body(cfg.mass, pymunk.moment_for_circle(cfg.mass, 0, cfg.radius))
        body.position = (x, y)
        body.angle = yaw
        disc = pymunk.Circle(body, cfg.radius)
        disc.friction = cfg.wall_friction
        control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        control.position = (x, y)
        control.angle = yaw
        pivot = pymunk.PivotJoint(control, body, (0, 0), (0, 0))
        pivot.max_bias = 0.0          # no positional correction: only velocity is driven
        pivot.max_force = cfg.pivot_max_force
        gear = pymunk.GearJoint(control, body, 0.0, 1.0)
        gear.error_bias = 0.0
        gear.max_bias = 0.0
        gear.max_force = cfg.gear_max_force
        space.add(body, disc, control, pivot, gear)
        space.step(0.0)  # lets pymunk run its checks of the new bodies once
        self.space, self.body, self.control = space, body, control
        # Chipmunk's C functions, called directly in drive(): the Python wrappers
        # (Space.step's bookkeeping for callbacks and deferred removals, none used here,
        # and the attribute setters) cost ~4x the physics itself. Public API as fallback.
        try:
            from pymunk._chipmunk import lib
            self._lib = lib
            self._space_ptr, self._body_ptr, self._control_ptr = space._space, body._body, control._body
        except (ImportError, AttributeError):
            self._lib = _PublicApi(space, body, control)
            self._space_ptr = self._body_ptr = self._control_ptr = None

    def drive(self, v: float, w: float, dt: float, steps: int, out: list) -> None:
        """Drive at forward speed v (m/s) and turn rate w (rad/s), robot frame, for `steps`
        physics steps of dt s, appending the pose (x, y, yaw unwrapped) after each to `out`.

        The joints have max_bias = 0, so only velocities are driven and the control
        body's position never matters: it is not re-anchored. The control velocity points
        along the heading at the middle of each step, so the body follows an arc.
        """
        lib, sp, b, k = self._lib, self._space_ptr, self._body_ptr, self._control_ptr
        get_angle, get_pos = lib.cpBodyGetAngle, lib.cpBodyGetPosition
        set_vel, space_step, append = lib.cpBodySetVelocity, lib.cpSpaceStep, out.append
        # The velocity solved in this step moves the body in the next one (Chipmunk
        # integrates positions before it solves the joints), while the body turns from
        # angle + w dt to angle + 2 w dt: point it along the middle of that turn.
        ahead = 1.5 * w * dt
        cos, sin = math.cos, math.sin
        lib.cpBodySetAngularVelocity(k, w)
        angle = get_angle(b)
        for _ in range(steps):
            a = angle + ahead
            set_vel(k, (v * cos(a), v * sin(a)))
            space_step(sp, dt)
            p = get_pos(b)
            angle = get_angle(b)
            append((p.x, p.y, angle))

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) now, yaw unwrapped (continuous)."""
        p = self.body.position
        return p.x, p.y, self.body.angle


class _PublicApi:
    """The four Chipmunk calls drive() makes, through pymunk's public API."""

    def __init__(self, space, body, control):
        self.space, self.body, self.control = space, body, control

    def cpBodyGetAngle(self, _):
        return self.body.angle

    def cpBodyGetPosition(self, _):
        return self.body.position

    def cpBodySetVelocity(self, _, vel):
        self.control.velocity = vel

    def cpBodySetAngularVelocity(self, _, w):
        self.control.angular_velocity = w

    def cpSpaceStep(self, _, dt):
        self.space.step(dt)
