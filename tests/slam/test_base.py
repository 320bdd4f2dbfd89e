"""The replay loop (slam.replay) and the registry (slam.registry) as the SLAM core uses them."""
import numpy as np
import pytest

from slam import registry
from slam.replay import _iter_inputs, run_algorithm
from worlds.yamlio import InputError

from tests.slam.synthlog import box_room_segments, make_log


@pytest.fixture(scope="module")
def log():
    return make_log(box_room_segments(), np.array([[1.0, 1.0], [2.0, 1.0]]), 0.5, seed=5)


def test_builtin_algorithms_registered(log):
    known = registry.algorithms()
    assert list(known)[:4] == ["pf", "gn", "graph", "oracle"]
    for name, cls in known.items():
        assert cls.name == name


def test_inputs_carry_timing_offset_and_imu_windows(log):
    items = list(_iter_inputs(log))
    assert len(items) == log.n_scans
    scan, odom, imu, truth = items[3]
    assert scan.time_increment == pytest.approx(0.2 / 360)
    np.testing.assert_allclose(scan.offset, [-0.032, 0.0, 0.0])
    assert np.all((imu.t > items[2][0].t) & (imu.t <= scan.t))
    assert truth.shape == (3,)


def test_inputs_carry_the_odometry_and_gyro_of_each_revolution(log):
    """A scan arrives when its revolution ends: the odometry at its last beam and the gyro
    samples taken while it turned come with it; past the odometry's end there is none."""
    from slam.pose import interpolate_poses
    items = list(_iter_inputs(log))
    scan, odom, imu, _ = items[3]
    end = scan.t + 359 * scan.time_increment
    np.testing.assert_allclose(odom.sweep_end, interpolate_poses(np.array([end]), log.odom_t, log.odom_pose)[0])
    in_sweep = (log.imu_t > scan.t) & (log.imu_t <= end)
    np.testing.assert_array_equal(imu.sweep_gyro, log.imu_gyro[in_sweep])
    assert len(imu.sweep_gyro) == 19      # 100 Hz from the first beam to the last (0.1994 s)
    late = log.odom_t[-1] < log.scan_t + 359 * scan.time_increment
    assert all((o.sweep_end is None) == bool(lt) for (_, o, _, _), lt in zip(items, late))


def test_stats_and_trajectory(log):
    res = run_algorithm("gn", log)
    assert res.stats["scans_processed"] == log.n_scans
    assert res.stats["realtime_factor"] > 0 and res.stats["algo"] == "gn"
    np.testing.assert_allclose(res.poses[0], log.start_pose)
    np.testing.assert_allclose(res.times, log.scan_t)


def test_unknown_algorithm(log):
    with pytest.raises(InputError, match="unknown algorithm"):
        run_algorithm("nope", log)
