import numpy as np
import pytest

from sim.lidar import LidarConfig, apply_range_noise, beam_poses, cast_scans
from sim.noise import load_profile
from tests.sim.worlds_fixtures import square_room


def _scan_at(world, pose, cfg=LidarConfig()):
    gt_t = np.array([0.0, 10.0])
    gt = np.array([pose, pose], float)
    o, a = beam_poses(np.array([0.0]), gt_t, gt, cfg)
    return cast_scans(world.segments, o, a, cfg.range_max)[0]


def test_square_room_hand_computed():
    # inner faces at 0.05 and 3.95; robot at (1, 2) facing +x, lidar 0.032 m behind: (0.968, 2)
    r = _scan_at(square_room(), (1.0, 2.0, 0.0))
    assert r.shape == (360,)
    assert r[0] == pytest.approx(3.95 - 0.968)
    assert r[90] == pytest.approx(3.95 - 2.0)
    assert r[180] == pytest.approx(0.968 - 0.05)
    assert r[270] == pytest.approx(2.0 - 0.05)
    assert r[45] == pytest.approx((3.95 - 2.0) * np.sqrt(2))          # hits the top wall
    assert r[225] == pytest.approx((0.968 - 0.05) * np.sqrt(2))       # hits the left wall


def test_square_room_rotated_robot():
    # facing +y: the lidar sits at (1, 2 - 0.032); beam 0 points up, beam 90 points left
    r = _scan_at(square_room(), (1.0, 2.0, np.pi / 2))
    assert r[0] == pytest.approx(3.95 - 1.968)
    assert r[90] == pytest.approx(1.0 - 0.05)
    assert r[180] == pytest.approx(1.968 - 0.05)
    assert r[270] == pytest.approx(3.95 - 1.0)


def test_beyond_range_is_inf():
    r = _scan_at(square_room(size=8.0), (1.0, 1.0, 0.0))
    assert np.isinf(r[0])                    # 6.9 m to the east wall
    assert r[180] == pytest.approx(1.0 - 0.032 - 0.05)


def test_motion_distortion_uses_each_beams_pose():
    cfg = LidarConfig()
    gt_t = np.array([0.0, 1.0])
    gt = np.array([[1.0, 2.0, 0.0], [2.0, 2.0, 0.0]])     # 1 m/s along +x
    o, a = beam_poses(np.array([0.0]), gt_t, gt, cfg)
    assert o[0, 0, 0] == pytest.approx(1.0 - 0.032)
    assert o[0, 180, 0] == pytest.approx(1.0 - 0.032 + 180 * cfg.time_increment)
    o2, _ = beam_poses(np.array([0.0]), gt_t, gt, LidarConfig(motion_distortion=False))
    assert np.allclose(o2[0, :, 0], 1.0 - 0.032)


def test_ideal_noise_only_quantises():
    cfg = LidarConfig()
    true = np.array([[0.5004, 1.23456, 3.4999, 3.6, 0.05, np.inf]])
    got = apply_range_noise(true, load_profile("ideal").lidar, cfg, np.random.default_rng(0))
    np.testing.assert_allclose(got[0, :3], [0.500, 1.235, 3.500])
    assert np.isinf(got[0, 3:]).all()


def test_realistic_noise_statistics():
    cfg = LidarConfig()
    noise = cfg.noise               # the realistic profile takes the LDS-01's datasheet
    true = np.concatenate([np.full(40000, 0.3), np.full(40000, 2.0)])
    got = apply_range_noise(true, noise, cfg, np.random.default_rng(1))
    near, far = got[:40000], got[40000:]
    for vals, mu, sigma in ((near, 0.3, 0.015 / 2), (far, 2.0, 0.05 * 2.0 / 2)):
        fin = vals[np.isfinite(vals)]
        assert np.mean(np.isinf(vals)) == pytest.approx(noise.drop_prob, abs=0.003)
        assert np.mean(fin) == pytest.approx(mu, abs=4 * sigma / np.sqrt(len(fin)) + 1e-3)
        assert np.std(fin) == pytest.approx(sigma, rel=0.03)
        # the datasheet's +- accuracy holds for ~95 % of the readings (2 sigma)
        assert np.mean(np.abs(fin - mu) <= 2 * sigma + 5e-4) == pytest.approx(0.954, abs=0.01)
    assert np.allclose(np.round(got[np.isfinite(got)] * 1000), got[np.isfinite(got)] * 1000)


def test_gazebo_noise_is_range_independent():
    noise = load_profile("gazebo").lidar
    got = apply_range_noise(np.full(20000, 3.0), noise, LidarConfig(range_max=10.0),
                            np.random.default_rng(2))
    assert np.std(got) == pytest.approx(0.01, rel=0.05)
    assert np.isfinite(got).all()
