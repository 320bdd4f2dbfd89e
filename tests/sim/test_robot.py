import numpy as np
import pytest

from sim.robot import DiffDriveRobot, RobotConfig, _PublicApi, twist_from_wheels, wheel_speeds
from tests.sim.worlds_fixtures import square_room

CFG = RobotConfig()


def test_wheel_speeds_and_back():
    left, right = wheel_speeds(0.1, 0.5, CFG)
    v, w = twist_from_wheels(left, right, CFG.wheel_radius, CFG.wheel_radius, CFG.wheel_separation)
    assert (v, w) == pytest.approx((0.1, 0.5))
    # over the limit: both wheels scaled, curvature kept
    left, right = wheel_speeds(0.22, 2.0, CFG)
    assert max(abs(left), abs(right)) == pytest.approx(CFG.max_wheel_speed)
    v, w = twist_from_wheels(left, right, CFG.wheel_radius, CFG.wheel_radius, CFG.wheel_separation)
    assert w / v == pytest.approx(2.0 / 0.22)


def _drive(robot, commands, dt=0.005):
    out = []
    for v, w, n in commands:
        robot.drive(v, w, dt, n, out)
    return np.array(out)


COMMANDS = [(0.2, 0.0, 200), (0.15, 0.5, 300), (0.0, -0.7, 100), (0.22, 0.3, 100)]


def test_free_body_follows_the_commanded_arc():
    robot = DiffDriveRobot(square_room(size=8.0), np.array([2.0, 2.0, 0.0]), CFG)
    poses = _drive(robot, [(0.2, 0.0, 200), (0.15, 0.5, 400)])
    # straight 1 s at 0.2 m/s; the body answers a step late, and the limited joint force
    # takes a step more to reach 0.2 m/s from rest
    assert poses[199, 0] == pytest.approx(2.0 + 0.2 * 0.99, abs=1.5e-3)
    assert poses[199, 1] == pytest.approx(2.0, abs=1e-9)
    # then an arc of radius v / w = 0.3 m (least-squares circle through the poses)
    x, y = poses[205:, 0], poses[205:, 1]
    a = np.c_[2 * x, 2 * y, np.ones_like(x)]
    cx, cy, _ = np.linalg.lstsq(a, x * x + y * y, rcond=None)[0]
    assert np.allclose(np.hypot(x - cx, y - cy), 0.3, atol=1e-6)
    # the body moves along its heading (the arc's tangent): what odometry assumes
    tangent = np.arctan2(np.diff(y), np.diff(x))
    mid_heading = 0.5 * (poses[205:-1, 2] + poses[206:, 2])
    assert np.abs(tangent - mid_heading).max() < 1e-6
    assert poses[-1, 2] == pytest.approx(0.5 * 399 * 0.005, abs=0.5 * 0.005)


def test_public_api_fallback_gives_the_same_motion():
    world = square_room()
    fast = DiffDriveRobot(world, np.array([1.0, 2.0, 0.3]), CFG)
    slow = DiffDriveRobot(world, np.array([1.0, 2.0, 0.3]), CFG)
    slow._lib = _PublicApi(slow.space, slow.body, slow.control)
    a, b = _drive(fast, COMMANDS), _drive(slow, COMMANDS)
    np.testing.assert_array_equal(a, b)
    assert robot_pose_close(fast.pose, a[-1])


def robot_pose_close(p, q):
    return np.allclose(np.asarray(p), np.asarray(q))


def test_wall_stops_the_body():
    # 4 m room: the east wall face is at x = 3.95; drive east for 30 s
    robot = DiffDriveRobot(square_room(), np.array([3.0, 2.0, 0.0]), CFG)
    poses = _drive(robot, [(0.22, 0.0, 6000)])
    assert poses[:, 0].max() <= 3.95 - CFG.radius + 0.005
    assert poses[-1, 0] == pytest.approx(3.95 - CFG.radius, abs=0.005)
