"""Covering routes: the shipped routes and planned routes see the walls; planner parts."""
import dataclasses
import itertools

import numpy as np
import pytest
import shapely

from worlds.coverage import resample_path, seen_share, seen_wall_cells, wall_coverage
from worlds.load import list_worlds, load_world, reachable_region, world_from_dict
from worlds.model import ROBOT_RADIUS
from worlds.route import _greedy_cover, _order, plan_route, route_for


def _path(world, route):
    return np.vstack([world.start[:2], route])


@pytest.mark.parametrize("name", list_worlds())
def test_shipped_routes_cover_the_walls(name):
    w = load_world(name)
    cov = wall_coverage(w, _path(w, route_for(w)), max_range=3.0)
    assert cov >= 0.99, f"{name}: {cov:.4f}"


def test_route_for_returns_the_yaml_route():
    w = load_world("swirl_s")
    r = route_for(w)
    np.testing.assert_array_equal(r, w.route)
    r[0, 0] = 99.0
    assert w.route[0, 0] != 99.0


def _check_planned(w, route):
    assert route.ndim == 2 and route.shape[1] == 2 and len(route) >= 1
    path = _path(w, route)
    region = reachable_region(w)
    assert region.covers(shapely.LineString(path) if len(path) > 1 else shapely.Point(path[0]))
    clear = shapely.distance(w.solid, shapely.points(resample_path(path, 0.02)))
    assert clear.min() >= ROBOT_RADIUS + 0.005
    return wall_coverage(w, path)


@pytest.fixture(scope="module")
def obstacle_plan():
    w = load_world("tests/data/worlds_obstacles.yaml")
    return w, route_for(w)


def test_planned_route_on_a_world_without_one(obstacle_plan):
    w, route = obstacle_plan
    assert w.route is None
    cov = _check_planned(w, route)
    assert cov >= 0.99, cov
    # a lone point sees far less: the planner did real work
    assert wall_coverage(w, w.start[None, :2]) < 0.8


@pytest.mark.parametrize("name", ["swirl_m", "rectangle_l", "loop"])
def test_planned_route_on_shipped_geometry(name):
    w = dataclasses.replace(load_world(name), route=None)
    route = plan_route(w)
    assert _check_planned(w, route) >= 0.99
    # keeps the preferred clearance where the corridors allow it
    assert shapely.distance(w.solid, shapely.points(route)).min() >= 0.25


def test_planned_route_is_deterministic(obstacle_plan):
    w, route = obstacle_plan
    np.testing.assert_array_equal(plan_route(w), route)


def test_wall_coverage_by_hand():
    e = 0.075
    w = world_from_dict({"walls": {"thickness": 0.12, "polylines": [
        [[-e, -e], [1 + e, -e], [1 + e, 1 + e], [-e, 1 + e], [-e, -e]]]},
        "robot": {"start": [0.5, 0.5, 0.0]}}, where="room.yaml")
    centre = np.array([[0.5, 0.5]])
    assert wall_coverage(w, centre, max_range=3.0) == 1.0
    assert wall_coverage(w, centre, max_range=0.5) == 0.0     # the walls are 0.515 m away
    # within 0.6 m: |t| <= sqrt(0.36 - 0.515^2) = 0.31 m of each wall's middle: ~13 of 21 cells
    part = wall_coverage(w, centre, max_range=0.6)
    assert 4 * 12 / 84 <= part <= 4 * 14 / 84
    seen, walls = seen_wall_cells(w, centre, max_range=0.6)
    assert walls.sum() == 84 and not (seen & ~walls).any()


def test_seen_share_counts_occupied_cells_holding_a_point():
    from worlds.raster import rasterize
    e = 0.075
    w = world_from_dict({"walls": {"thickness": 0.12, "polylines": [
        [[-e, -e], [1 + e, -e], [1 + e, 1 + e], [-e, 1 + e], [-e, -e]]]},
        "robot": {"start": [0.5, 0.5, 0.0]}}, where="room.yaml")
    truth = rasterize(w)
    walls = truth.occupied_xy()
    assert seen_share(truth, walls) == 1.0
    assert seen_share(truth, walls[:21]) == pytest.approx(21 / 84)
    # free cells, points outside the grid and repeats add nothing
    far = np.array([[0.5, 0.5], [50.0, 50.0], walls[0], walls[0]])
    assert seen_share(truth, far) == pytest.approx(1 / 84)


def test_order_matches_brute_force():
    rng = np.random.default_rng(3)
    for _ in range(20):
        pts = rng.uniform(0, 10, size=(8, 2))
        d = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1))
        tour = _order(d)
        assert tour[0] == 0 and sorted(tour) == list(range(8))
        cost = sum(d[a, b] for a, b in zip(tour[:-1], tour[1:]))
        best = min(sum(d[a, b] for a, b in zip((0,) + p[:-1], p))
                   for p in itertools.permutations(range(1, 8)))
        assert cost <= 1.05 * best + 1e-9


def test_greedy_cover():
    sets = [np.array([1, 2, 3]), np.array([3, 4]), np.array([4, 5, 6, 7]), np.array([1, 7])]
    chosen = _greedy_cover(sets, np.arange(1, 8))
    assert chosen == [2, 0]
    assert _greedy_cover(sets, np.array([9])) == []


def test_chamfer_cuts_free_corners_and_keeps_viewpoints():
    from worlds.route import _chamfer
    w = load_world("rectangle_l")
    path = np.array([[1.0, 1.0], [4.0, 1.0], [4.0, 4.0], [7.0, 4.0]])
    out = _chamfer(path, w, np.array([True, False, True, False]))
    # the corner at (4, 1) becomes a 0.2 m chord, the viewpoint at (4, 4) stays
    np.testing.assert_allclose(out, [[1.0, 1.0], [3.8, 1.0], [4.0, 1.2], [4.0, 4.0], [7.0, 4.0]])
    # a corner whose chord would come within min_clear of a wall is left alone
    near = np.array([[1.0, 0.2], [8.8, 0.2], [8.8, 3.0]])
    np.testing.assert_allclose(_chamfer(near, w, np.zeros(3, bool), min_clear=0.25), near)


def test_no_room_to_plan():
    from worlds.yamlio import InputError
    # a 0.24 m box: the start fits (0.105 m from each wall) but no cell centre keeps 0.115 m
    e = 0.06
    w = world_from_dict({"walls": {"thickness": 0.1, "polylines": [
        [[-e, -e], [0.22 + e, -e], [0.22 + e, 0.22 + e], [-e, 0.22 + e], [-e, -e]]]},
        "robot": {"start": [0.11, 0.11, 0.0]}}, where="tiny.yaml")
    with pytest.raises(InputError, match="tiny.yaml: route: no room to plan a route"):
        plan_route(w)
