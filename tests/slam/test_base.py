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


def test_stats_and_trajectory(log):
    res = run_algorithm("gn", log)
    assert res.stats["scans_processed"] == log.n_scans
    assert res.stats["realtime_factor"] > 0 and res.stats["algo"] == "gn"
    np.testing.assert_allclose(res.poses[0], log.start_pose)
    np.testing.assert_allclose(res.times, log.scan_t)


def test_unknown_algorithm(log):
    with pytest.raises(InputError, match="unknown algorithm"):
        run_algorithm("nope", log)
