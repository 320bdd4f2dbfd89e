import numpy as np
import pytest
from shapely.geometry import LineString, Point

from sim.controller import ControllerConfig, PurePursuit


def _drive(path, cfg=ControllerConfig(), start_yaw=0.0, dt=0.02, t_max=200.0):
    ctrl = PurePursuit(path, cfg)
    x, y, yaw = path[0][0], path[0][1], start_yaw
    out = []
    t = 0.0
    while t < t_max:
        v, w = ctrl.command(x, y, yaw, t, dt)
        if ctrl.done:
            break
        out.append((t, x, y, yaw, v, w))
        x += v * np.cos(yaw + w * dt / 2) * dt
        y += v * np.sin(yaw + w * dt / 2) * dt
        yaw += w * dt
        t += dt
    return ctrl, np.array(out)


def test_follows_an_l_shaped_route_within_limits():
    path = np.array([[0, 0], [3, 0], [3, 2], [1, 2]], float)
    cfg = ControllerConfig()
    ctrl, rec = _drive(path, cfg)
    assert ctrl.done and not ctrl.stuck
    assert np.hypot(rec[-1, 1] - 1, rec[-1, 2] - 2) < 0.1
    v, w = rec[:, 4], rec[:, 5]
    assert v.max() <= cfg.max_linear + 1e-12 and v.min() >= 0
    assert np.abs(w).max() <= cfg.max_turn_rate + 1e-12
    assert np.diff(v).max() <= cfg.accel * 0.02 + 1e-12          # ramped up gradually
    assert v[:50].max() < cfg.max_linear                         # not at full speed at once
    line = LineString(path)
    assert max(line.distance(Point(p)) for p in rec[:, 1:3]) < 0.25   # corners cut < lookahead
    assert v.max() == pytest.approx(cfg.max_linear)


def test_turns_in_place_when_facing_away():
    path = np.array([[0, 0], [-2, 0]], float)
    ctrl, rec = _drive(path, start_yaw=0.0)
    assert ctrl.done
    first = rec[:20]
    assert np.all(first[:, 4] == 0) and np.all(np.abs(first[:, 5]) > 0)   # rotate first
    assert np.hypot(rec[:, 1], rec[:, 2]).max() < 2.1


def test_stuck_robot_times_out():
    cfg = ControllerConfig(stuck_timeout=5.0)
    ctrl = PurePursuit(np.array([[0, 0], [3, 0]], float), cfg)
    t = 0.0
    while not ctrl.done and t < 60:
        ctrl.command(0.0, 0.0, 0.0, t, 0.02)      # never moves
        t += 0.02
    assert ctrl.done and ctrl.stuck and 5.0 < t < 6.0


def test_a_path_passing_near_itself_is_followed_in_order():
    # out along y = 0, back along y = 0.3: progress must not jump to the return leg
    path = np.array([[0, 0], [4, 0], [4, 0.3], [0, 0.3]], float)
    ctrl, rec = _drive(path)
    assert ctrl.done and rec[:, 1].max() > 3.7


def test_zero_length_route_is_done_at_once():
    ctrl = PurePursuit(np.array([[1, 1], [1, 1]], float), ControllerConfig())
    assert ctrl.done and ctrl.command(1.0, 1.0, 0.0, 0.0, 0.02) == (0.0, 0.0)
    with pytest.raises(ValueError):
        PurePursuit(np.zeros((0, 2)), ControllerConfig())


def test_closed_route_drives_all_the_way_round_and_back():
    # ends where it starts and the first leg is straight ahead: the straight line to the end
    # is zero at the start, the distance left along the route is the whole route
    path = np.array([[0, 0], [3, 0], [3, 2], [0, 2], [0, 0]], float)
    ctrl, rec = _drive(path)
    assert ctrl.done and not ctrl.stuck
    assert rec[:, 1].max() > 2.8 and rec[:, 2].max() > 1.8
    assert rec[:, 4].max() == pytest.approx(ControllerConfig().max_linear)
    x, y = rec[-1, 1], rec[-1, 2]
    assert np.hypot(x, y) < 0.1


def test_route_that_revisits_a_waypoint_is_driven_in_order():
    # out to (2, 0), over to (2, 1.5), back through (2, 0) and home: (2, 0) is visited twice
    path = np.array([[0, 0], [2, 0], [2, 1.5], [2, 0], [0, 0]], float)
    ctrl, rec = _drive(path)
    assert ctrl.done and not ctrl.stuck
    assert rec[:, 2].max() > 1.3
    assert np.hypot(rec[-1, 1], rec[-1, 2]) < 0.1


@pytest.mark.parametrize("first", [(2.0, 0.0), (-2.0, 0.0), (0.0, 2.0), (0.0, -2.0)],
                         ids=["ahead", "behind", "left", "right"])
def test_first_waypoint_in_any_direction(first):
    path = np.array([[0, 0], first, [first[0] + 1.0, first[1] + 1.0]], float)
    ctrl, rec = _drive(path, start_yaw=0.0)
    assert ctrl.done and not ctrl.stuck
    assert np.hypot(rec[-1, 1] - path[-1, 0], rec[-1, 2] - path[-1, 1]) < 0.1
    line = LineString(path)
    assert max(line.distance(Point(p)) for p in rec[:, 1:3]) < 0.3

