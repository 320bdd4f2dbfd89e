"""The particle-filter SLAM `pf` on short synthetic logs: seeds, odometry bias, bad input."""
import dataclasses

import numpy as np
import pytest

from sim.logs import SensorLog
from slam import registry
from slam.replay import run_algorithm
from slam.pf import ParticleFilterSlam, PfConfig
from slam.pose import compose, interpolate_poses, relative
from worlds.yamlio import InputError
from tests.slam.synthlog import box_room_segments, make_log, square_route

SMALL = {"particles": 10}


@pytest.fixture(scope="module")
def room_log():
    return make_log(box_room_segments(), square_route(), seed=5, range_sigma=0.01)


def _biased(log: SensorLog, scale: float = 1.06, yaw_per_m: float = 0.06) -> SensorLog:
    """The log with its odometry re-integrated from increments scaled by `scale` and turned
    by yaw_per_m rad per metre: a known systematic odometry error."""
    inc = relative(log.odom_pose[:-1], log.odom_pose[1:])
    inc[:, :2] *= scale
    inc[:, 2] += yaw_per_m * np.hypot(inc[:, 0], inc[:, 1])
    poses = [log.odom_pose[0]]
    for d in inc:
        poses.append(compose(poses[-1], d))
    return SensorLog(**{**{k: getattr(log, k) for k in (
        "scan_t", "scan_ranges", "scan_angles", "odom_t", "odom_twist", "imu_t", "imu_gyro",
        "imu_accel", "imu_yaw", "gt_t", "gt_pose")}, "odom_pose": np.array(poses), "meta": log.meta})


def _rmse(times, poses, log):
    gt = interpolate_poses(times, log.gt_t, log.gt_pose)
    return float(np.sqrt(np.mean(np.sum((poses[:, :2] - gt[:, :2]) ** 2, axis=1))))


def test_registered_with_gmapping_defaults():
    assert registry.get("pf") is ParticleFilterSlam
    c = PfConfig()
    assert (c.particles, c.resample_threshold, c.delta) == (30, 0.5, 0.025)
    # the TurtleBot3's odometry (the gyro's heading) and a motion model to match it
    assert c.odometry_heading == "imu"
    assert (c.motion.srr, c.motion.srt, c.motion.str, c.motion.stt) == (0.03, 0.02, 0.02, 0.02)
    assert (c.matcher.lsigma, c.matcher.iterations, c.matcher.lstep, c.matcher.astep) == (0.075, 5, 0.05, 0.05)


def test_config_rejects_unknown_keys_and_bad_values(room_log):
    with pytest.raises(InputError, match="did you mean 'particles'"):
        run_algorithm("pf", room_log, config={"particle": 3})
    with pytest.raises(InputError, match="particles"):
        run_algorithm("pf", room_log, config={"particles": 0})


def test_log_without_odometry_is_refused(room_log):
    bare = SensorLog(scan_t=room_log.scan_t, scan_ranges=room_log.scan_ranges,
                     scan_angles=room_log.scan_angles, meta=room_log.meta)
    with pytest.raises(InputError, match="'pf' needs wheel odometry"):
        run_algorithm("pf", bare)


def _head(log: SensorLog, n: int) -> SensorLog:
    """The first n scans of the log (the other sensors kept whole)."""
    arrays = {k: getattr(log, k) for k in ("scan_angles", "odom_t", "odom_pose", "odom_twist",
                                            "imu_t", "imu_gyro", "imu_accel", "imu_yaw", "gt_t", "gt_pose")}
    return SensorLog(scan_t=log.scan_t[:n], scan_ranges=log.scan_ranges[:n], meta=log.meta, **arrays)


def test_same_seed_same_map_other_seed_other_map(room_log):
    log = _head(room_log, 100)
    a = run_algorithm("pf", log, config=SMALL, seed=1)
    b = run_algorithm("pf", log, config=SMALL, seed=1)
    c = run_algorithm("pf", log, config=SMALL, seed=2)
    assert a.grid.equals(b.grid)
    np.testing.assert_array_equal(a.poses, b.poses)
    assert not np.array_equal(a.poses, c.poses)
    assert not (a.grid.shape == c.grid.shape and np.array_equal(a.grid.prob, c.grid.prob, equal_nan=True))
    assert len(a.times) == log.n_scans
    assert a.stats["filter_updates"] > 5


def test_a_throttled_filter_runs_as_on_the_scans_it_takes(room_log):
    # no beam timing: the de-skew would otherwise see a different previous scan
    meta = {**room_log.meta, "lidar": {**room_log.meta["lidar"], "time_increment": 0.0}}
    log = dataclasses.replace(_head(room_log, 120), meta=meta)
    every_third = dataclasses.replace(log, scan_t=log.scan_t[::3], scan_ranges=log.scan_ranges[::3])
    # the wheels' odometry: the gyro's heading is integrated scan by scan, throttled or not
    wheels = {**SMALL, "odometry_heading": "wheels"}
    throttled = run_algorithm("pf", log, config={**wheels, "throttle_scans": 3}, seed=4)
    taken = run_algorithm("pf", every_third, config={**wheels, "throttle_scans": 1}, seed=4)
    assert len(throttled.times) == log.n_scans     # every scan keeps its place on the trajectory
    np.testing.assert_allclose(throttled.poses[::3], taken.poses, atol=1e-9)
    assert throttled.stats["filter_updates"] == taken.stats["filter_updates"] > 5
    every = run_algorithm("pf", log, config={**wheels, "throttle_scans": 1}, seed=4)
    assert not np.allclose(every.poses[::3], taken.poses, atol=1e-6)


@pytest.mark.parametrize("heading", ["wheels", "imu"])
def test_filter_beats_biased_odometry(room_log, heading):
    log = _biased(room_log)
    odom = interpolate_poses(log.scan_t, log.odom_t, log.odom_pose)
    odom = compose(log.start_pose, relative(odom[0], odom))
    odom_err = _rmse(log.scan_t, odom, log)
    # the wheels' odometry with GMapping's noise; the gyro's heading with the default noise
    config = ({**SMALL, "odometry_heading": "wheels",
               "motion": {"srr": 0.1, "srt": 0.2, "str": 0.1, "stt": 0.2}}
              if heading == "wheels" else SMALL)
    res = run_algorithm("pf", log, config=config, seed=0)
    pf_err = _rmse(res.times, res.poses, log)
    assert odom_err > 0.25  # the bias is large
    assert pf_err < 0.3 * odom_err
    assert pf_err < 0.06


def test_stock_gmapping_config_switches_the_additions_off():
    from pathlib import Path
    from slam.registry import load_config
    stock = load_config("pf", Path(__file__).parents[3] / "slam" / "configs" / "pf_gmapping.yaml")
    assert (stock.smooth_beams, stock.matcher.gn_iterations) == (0, 0)
    assert (stock.motion.srr, stock.motion.srt, stock.motion.str, stock.motion.stt) == (0.1, 0.2, 0.1, 0.2)
    assert PfConfig().matcher.gn_iterations > 0
