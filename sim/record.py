"""record(): drive a world's route with the simulated robot and record a SensorLog.

The only loop of the simulator: every control period the pure-pursuit controller turns
the true pose into a twist, the twist into wheel speeds (what the motors turn and the
encoders count), the wheel speeds with the run's slip into the twist the physics body is
driven at; pymunk steps at physics_dt and the true pose is kept at every step. The
sensors are then computed from those arrays, vectorised: lidar beams cast from poses
interpolated at each beam's time, encoder ticks from the wheel speeds, IMU from the true
trajectory. Randomness: rng = default_rng(seed), one spawned child per noise source, so
the same world, seed, profile and config give byte-identical logs.

A log says how the recording went (meta): `ending` ("end": the route was driven;
"stuck": no progress for the controller's stuck_timeout; "time limit": max_duration ran
out), `route_length` and `route_driven` (m and share of the route's arc length reached),
and `wall_coverage`: the share of the true map's occupied cells in which a noise-free beam
of the log (every beam of every scan, within the lidar's range) ended. `recording_problem`
turns those into the reason a log cannot be trusted, or None.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from sim._coverage import mark_beam_ends_inplace
from sim.controller import ControllerConfig, PurePursuit
from sim.imu import simulate_imu
from sim.lidar import LidarConfig, apply_range_noise, beam_poses, cast_scans, load_lidar
from sim.logs import SensorLog
from sim.noise import NoiseProfile, load_profile
from sim.odometry import encoder_ticks, integrate_ticks, odometry_drift, wheel_angles_at
from sim.robot import DiffDriveRobot, RobotConfig, twist_from_wheels, wheel_speeds
from worlds.model import World
from worlds.yamlio import InputError, from_dict, load_yaml, to_dict

__all__ = ["RecordConfig", "load_record_config", "record", "recording_problem", "SIM_VERSION",
           "MIN_COVERAGE"]

# bump when the recorded data for the same world, seed and profile changes
SIM_VERSION = "3"
# below this share of the true wall cells seen, a log cannot give a complete map
MIN_COVERAGE = 0.95


@dataclass(frozen=True)
class RecordConfig:
    physics_dt: float = 0.005      # s (200 Hz)
    control_rate: float = 50.0     # Hz, controller and slip updates
    odom_rate: float = 30.0        # Hz (TurtleBot3 core publishes odom at 30 Hz)
    imu_rate: float = 100.0        # Hz
    max_duration: float = 3600.0   # s of simulated time
    min_duration: float = 1.0      # s: the robot stands still at the end until this time
    robot: RobotConfig = field(default_factory=RobotConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    lidar: LidarConfig = field(default_factory=LidarConfig)

    def __post_init__(self):
        for n in ("physics_dt", "control_rate", "odom_rate", "imu_rate", "max_duration"):
            if getattr(self, n) <= 0:
                raise ValueError(f"{n} must be > 0")
        if not 0 <= self.min_duration <= self.max_duration:
            raise ValueError("need 0 <= min_duration <= max_duration")
        for n in ("control_rate", "imu_rate"):
            k = 1.0 / (getattr(self, n) * self.physics_dt)
            if abs(k - round(k)) > 1e-6:
                raise ValueError(f"1 / ({n} * physics_dt) must be a whole number of physics steps")

    @property
    def control_every(self) -> int:
        return int(round(1.0 / (self.control_rate * self.physics_dt)))

    @property
    def imu_every(self) -> int:
        return int(round(1.0 / (self.imu_rate * self.physics_dt)))


def load_record_config(config: "RecordConfig | Mapping | str | Path | None") -> RecordConfig:
    """RecordConfig from None (defaults), a mapping, a YAML path or a RecordConfig."""
    if config is None:
        return RecordConfig()
    if isinstance(config, RecordConfig):
        return config
    if isinstance(config, Mapping):
        return from_dict(RecordConfig, config, where="<config>")
    return from_dict(RecordConfig, load_yaml(config), where=str(config))


def _route(world: World) -> np.ndarray:
    try:
        from worlds import route_for  # the covering-route planner, when present
    except ImportError:
        route_for = None
    if route_for is not None:
        return np.asarray(route_for(world), dtype=np.float64).reshape(-1, 2)
    if world.route is None:
        raise InputError(f"{world.source or world.name}: no route, and no route planner available")
    return np.asarray(world.route, dtype=np.float64).reshape(-1, 2)


def _drive(world: World, route: np.ndarray, cfg: RecordConfig, noise: NoiseProfile,
           rng: np.random.Generator):
    """Run the physics. Returns gt (L, 3) (yaw unwrapped, row i at i * physics_dt),
    step_t (C + 1,) control-step boundaries, wheel (C, 2) commanded wheel speeds rad/s,
    how the run ended ("end", "stuck" or "time limit") and the controller (its progress and path length)."""
    rc = cfg.robot
    start = np.asarray(world.start, dtype=np.float64)
    path = np.vstack([start[:2], route])
    ctrl = PurePursuit(path, cfg.controller)
    robot = DiffDriveRobot(world, start, rc)
    sys_rng, slip_rng = rng.spawn(2)
    wn = noise.wheels
    # systematic errors, drawn once (Borenstein & Feng 1996)
    r_left = rc.wheel_radius * (1.0 + wn.radius_error * sys_rng.standard_normal())
    r_right = rc.wheel_radius * (1.0 + wn.radius_error * sys_rng.standard_normal())
    sep = rc.wheel_separation * (1.0 + wn.separation_error * sys_rng.standard_normal())
    dt = cfg.physics_dt
    every = cfg.control_every
    dt_c = dt * every
    n_ctrl_max = int(math.ceil(cfg.max_duration / dt_c))
    slip_chunk = []
    gt = [robot.pose]
    wheel = []
    ending = "time limit"
    # per-step Python: plain floats and locals (numpy scalars cost ~10x a float operation)
    drive, command, sqrt = robot.drive, ctrl.command, math.sqrt
    radius, slip = rc.wheel_radius, wn.slip_density
    for k in range(n_ctrl_max):
        x, y, a = gt[-1]
        v, w = command(x, y, a, k * dt_c, dt_c)
        if ctrl.done:
            ending = "stuck" if ctrl.stuck else "end"
            break
        wl, wr = wheel_speeds(v, w, rc)
        wheel.append((wl, wr))
        if k % 1000 == 0:
            slip_chunk = slip_rng.standard_normal((1000, 2)).tolist()
        el, er = slip_chunk[k % 1000]
        # ground travel of each wheel in this control step: effective radius plus slip whose
        # variance grows with the wheel's travel (Chong & Kleeman 1997)
        dl = wl * dt_c * radius
        dr = wr * dt_c * radius
        gl = wl * dt_c * r_left + slip * sqrt(abs(dl)) * el
        gr = wr * dt_c * r_right + slip * sqrt(abs(dr)) * er
        vt, wt = twist_from_wheels(gl / dt_c, gr / dt_c, 1.0, 1.0, sep)
        drive(vt, wt, dt, every, gt)
    # a route that ends (or is empty) early: stand still, so the log holds a few scans
    while len(wheel) * dt_c < cfg.min_duration - 1e-9:
        wheel.append((0.0, 0.0))
        drive(0.0, 0.0, dt, every, gt)
    gt = np.asarray(gt, dtype=np.float64)
    wheel = np.asarray(wheel, dtype=np.float64).reshape(-1, 2)
    # Chipmunk integrates positions before it solves the joints, so the body answers a
    # command one physics step later: the wheels turn (and the encoders count) in step
    # with the body, i.e. one step after the command.
    step_t = np.arange(len(wheel) + 1) * dt_c + dt
    return gt, step_t, wheel, ending, ctrl


def _seen_share(world: World, origins: np.ndarray, angles: np.ndarray, ranges: np.ndarray,
                lc: LidarConfig) -> float:
    """Share of the true map's occupied cells holding the end of a beam within the lidar's
    range. origins (N, B, 2) m, angles (N, B) rad, ranges (N, B) m, noise-free."""
    from worlds.coverage import occupied_share
    from worlds.raster import true_walls
    walls = true_walls(world)
    ranges = ranges.reshape(-1)
    beams = np.flatnonzero(np.isfinite(ranges) & (ranges >= lc.range_min) & (ranges <= lc.range_max))
    a = angles.reshape(-1)[beams]
    ox, oy, yaw = walls.origin
    frame = np.array([ox, oy, walls.resolution, np.cos(yaw), np.sin(yaw)])
    hit = np.zeros(walls.shape, dtype=bool)
    # a beam ends on the surface: a face on a cell edge belongs to the cell on either side
    # (worlds.raster takes the floor), so take the points a micrometre before and after it
    mark_beam_ends_inplace(hit, frame, origins.reshape(-1, 2), ranges, beams, np.cos(a), np.sin(a),
                           1e-6)
    return occupied_share(walls, hit)


def recording_problem(meta: Mapping, min_coverage: float = MIN_COVERAGE) -> str | None:
    """Why a simulated log cannot be trusted (it did not finish its route, or saw less than
    `min_coverage` of the true wall cells), or None. Logs without these meta keys (real
    logs, older simulators) pass."""
    ending = meta.get("ending")
    if ending == "timeout":           # older logs
        ending = "time limit"
    if ending in ("stuck", "time limit"):
        length = meta.get("route_length")
        driven = meta.get("route_driven")
        if length is not None and driven is not None:
            how = f" after {driven * length:.1f} m of {length:.1f} m"
        else:
            how = ""
        what = "ended stuck" if ending == "stuck" else "hit the time limit"
        return f"log {what}{how}"
    cover = meta.get("wall_coverage")
    if cover is not None and cover < min_coverage:
        return f"log saw {100 * cover:.1f} % of the wall cells (< {100 * min_coverage:.0f} %)"
    return None


def record(world: World, seed: int = 0, noise: "str | Path | NoiseProfile" = "realistic",
           config: "RecordConfig | Mapping | str | Path | None" = None,
           lidar: "str | Path | LidarConfig | None" = None) -> SensorLog:
    """Drive the world's route (worlds.route_for) and record every sensor.

    noise: profile name, YAML path or NoiseProfile; config: RecordConfig, mapping, YAML
    path or None; lidar: a catalogue name, a lidar YAML file or a LidarConfig in place of
    the config's lidar (mounted where the config's lidar is). Same world, seed, profile,
    config and lidar: identical SensorLog arrays.
    """
    profile = load_profile(noise)
    cfg = load_record_config(config)
    if lidar is not None:
        cfg = dataclasses.replace(cfg, lidar=load_lidar(lidar, mounted_as=cfg.lidar))
    route = _route(world)
    rng = np.random.default_rng(seed)
    drive_rng, lidar_rng, imu_rng = rng.spawn(3)
    gt, step_t, wheel, ending, ctrl = _drive(world, route, cfg, profile, drive_rng)
    dt = cfg.physics_dt
    gt_t = np.arange(len(gt)) * dt
    t_end = gt_t[-1]
    start = np.asarray(world.start, dtype=np.float64)
    rc = cfg.robot
    lc = cfg.lidar

    # lidar: revolutions that complete before the end
    n_scans = int(math.floor((t_end - lc.scan_time) * lc.rate + 1e-9)) + 1 if t_end >= lc.scan_time else 0
    scan_t = np.arange(n_scans) / lc.rate
    origins, angles = beam_poses(scan_t, gt_t, gt, lc)
    true_ranges = cast_scans(world.segments, origins, angles, np.inf).reshape(n_scans, lc.beams)
    lidar_noise = profile.lidar if profile.lidar is not None else lc.noise
    scan_ranges = apply_range_noise(true_ranges, lidar_noise, lc, lidar_rng)
    coverage = _seen_share(world, origins, angles, true_ranges, lc) if n_scans else 0.0

    # wheel odometry from encoder ticks
    odom_t = np.arange(int(math.floor(t_end * cfg.odom_rate + 1e-9)) + 1) / cfg.odom_rate
    ticks = encoder_ticks(wheel_angles_at(odom_t, step_t, wheel), rc.encoder_ticks)
    odom_pose, odom_twist = integrate_ticks(odom_t, ticks, start, rc.encoder_ticks,
                                            rc.wheel_radius, rc.wheel_separation)

    # IMU
    idx, gyro, accel, imu_yaw = simulate_imu(gt, dt, cfg.imu_every, profile.imu, float(start[2]), imu_rng)
    imu_t = gt_t[idx]

    gt_pose = gt.copy()
    gt_pose[:, 2] = np.mod(gt[:, 2] + np.pi, 2 * np.pi) - np.pi
    drift = odometry_drift(odom_t, odom_pose, gt_t, gt)
    meta = {
        "sim_version": SIM_VERSION,
        "world": world.name,
        "world_source": str(world.source) if world.source else "",
        "seed": int(seed),
        "noise": {**profile.to_dict(), "lidar": to_dict(lidar_noise)},
        "lidar": lc.meta(),
        "robot": to_dict(rc),
        "odometry": {"rate": cfg.odom_rate, "encoder_ticks": rc.encoder_ticks},
        "imu": {"rate": cfg.imu_rate},
        "start_pose": [float(v) for v in start],
        "route": route.tolist(),
        "ending": ending,
        "route_length": float(ctrl.length),
        "route_driven": 1.0 if ending == "end" else float(ctrl.s / max(ctrl.length, 1e-9)),
        "wall_coverage": float(coverage),
        "config": to_dict(cfg),
        "odometry_drift": drift,
    }
    return SensorLog(scan_t=scan_t, scan_ranges=scan_ranges, scan_angles=lc.angles,
                     odom_t=odom_t, odom_pose=odom_pose, odom_twist=odom_twist,
                     imu_t=imu_t, imu_gyro=gyro, imu_accel=accel, imu_yaw=imu_yaw,
                     gt_t=gt_t, gt_pose=gt_pose, meta=meta)
