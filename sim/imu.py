"""Planar IMU: z gyro, x/y accelerometer (body frame: x forward, y left), integrated yaw.

True rates come from the true trajectory at the physics step (central differences of
yaw and of position, so collisions show up as acceleration spikes). Each channel gets
white Gaussian noise plus a bias (constant, drawn once, random sign, as Gazebo's
GaussianNoiseModel does, and a random walk for in-run drift). The yaw is the running
integral of the measured gyro from the start yaw, as the TurtleBot3 IMU reports an
orientation integrated on board: its error grows with the gyro bias.
"""
from __future__ import annotations

import numpy as np

from sim.noise import ImuAxisNoise, ImuNoise

__all__ = ["true_imu", "channel_noise", "simulate_imu"]


def true_imu(gt_pose: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """True yaw rate (L,) rad/s and body-frame acceleration (L, 2) m/s^2 at every physics
    step of gt_pose (L, 3) (yaw unwrapped), step dt s. Central differences inside,
    one-sided at the ends."""
    yaw_rate = np.gradient(gt_pose[:, 2], dt)
    vel = np.gradient(gt_pose[:, :2], dt, axis=0)
    acc = np.gradient(vel, dt, axis=0)
    c, s = np.cos(gt_pose[:, 2]), np.sin(gt_pose[:, 2])
    body = np.stack([c * acc[:, 0] + s * acc[:, 1], -s * acc[:, 0] + c * acc[:, 1]], axis=1)
    return yaw_rate, body


def channel_noise(n: int, dt: float, noise: ImuAxisNoise, rng: np.random.Generator) -> np.ndarray:
    """Additive error (n,) of one channel sampled every dt s: bias + random walk + white."""
    sign = 1.0 if rng.random() < 0.5 else -1.0
    bias = sign * (noise.bias_mean + noise.bias_stddev * rng.standard_normal())
    walk = np.cumsum(rng.standard_normal(n)) * (noise.bias_walk * np.sqrt(dt))
    white = rng.standard_normal(n) * noise.sigma(1.0 / dt)
    return bias + walk + white


def simulate_imu(gt_pose: np.ndarray, physics_dt: float, every: int, noise: ImuNoise,
                 start_yaw: float, rng: np.random.Generator):
    """IMU samples at every `every`-th physics step.

    gt_pose: (L, 3) true poses at physics steps (yaw unwrapped). Returns index (K,) of the
    physics steps sampled, gyro (K,) rad/s, accel (K, 2) m/s^2, yaw (K,) rad wrapped.
    """
    rate, acc = true_imu(gt_pose, physics_dt)
    idx = np.arange(0, len(gt_pose), every)
    dt = physics_dt * every
    g_rng, ax_rng, ay_rng = rng.spawn(3)
    gyro = rate[idx] + channel_noise(len(idx), dt, noise.gyro, g_rng)
    accel = acc[idx] + np.stack([channel_noise(len(idx), dt, noise.accel, ax_rng),
                                 channel_noise(len(idx), dt, noise.accel, ay_rng)], axis=1)
    # trapezoidal integration, as an on-board attitude filter between samples
    yaw = start_yaw + np.concatenate([[0.0], np.cumsum(0.5 * (gyro[1:] + gyro[:-1]) * dt)])
    return idx, gyro, accel, np.mod(yaw + np.pi, 2 * np.pi) - np.pi
