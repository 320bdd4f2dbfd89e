"""World YAML loading: shipped worlds, schema, and one test per kind of bad world."""
import math

import numpy as np
import pytest
import shapely
import yaml

from worlds.load import list_worlds, load_world, reachable_region
from worlds.model import ROBOT_RADIUS
from worlds.yamlio import InputError

SEVEN = ["rectangle_s", "rectangle_m", "rectangle_l", "swirl_s", "swirl_m", "swirl_l", "corridor"]

GOOD = {
    "name": "box_room",
    "walls": {"thickness": 0.12, "polylines": [[[-0.075, -0.075], [2.075, -0.075], [2.075, 2.075],
                                                [-0.075, 2.075], [-0.075, -0.075]]]},
    "robot": {"start": [0.5, 0.5, 0.0]},
    "route": [[1.5, 0.5], [1.5, 1.5]],
}


def _write(tmp_path, data, name="bad.yaml"):
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data) if not isinstance(data, str) else data)
    return p


def _with(**changes):
    import copy
    d = copy.deepcopy(GOOD)
    for k, v in changes.items():
        d[k] = v
    return d


def test_shipped_worlds_are_listed_and_load():
    names = list_worlds()
    assert set(SEVEN) <= set(names) and "loop" in names
    for n in names:
        w = load_world(n)
        assert w.name == n
        assert w.route is not None and len(w.route) >= 2
        assert w.free_space.area > 1.0


@pytest.mark.parametrize("name,w,h", [("rectangle_s", 3, 2), ("rectangle_m", 6, 4), ("rectangle_l", 9, 6),
                                      ("swirl_s", 3, 3), ("swirl_m", 5, 5), ("swirl_l", 7, 7),
                                      ("corridor", 2, 10), ("loop", 12, 8)])
def test_shipped_world_sizes(name, w, h):
    x0, y0, x1, y1 = load_world(name).free_space.bounds
    assert abs((x1 - x0) - w) < 0.05 and abs((y1 - y0) - h) < 0.05


@pytest.mark.parametrize("name", SEVEN + ["loop"])
def test_wall_surfaces_avoid_cell_edges(name):
    """Every wall surface lies 0.015 m past a 0.05 m cell edge (never on one), on the solid side
    of the centre of the cell it lies in: the rasterizer's and a lidar's cells then agree."""
    w = load_world(name)
    assert w.resolution == 0.05
    for ring in [w.free_space.exterior, *w.free_space.interiors]:
        xy = np.asarray(ring.coords)
        for a, b in zip(xy[:-1], xy[1:]):
            vertical, horizontal = abs(a[0] - b[0]) < 1e-9, abs(a[1] - b[1]) < 1e-9
            assert vertical != horizontal, (name, a, b)
            axis = 0 if vertical else 1      # the coordinate that is constant along the surface
            frac = (a[axis] / 0.05) % 1.0
            assert min(abs(frac - 0.3), abs(frac - 0.7)) < 1e-6, (name, a, b)
            # the cell holding the surface has its centre inside the solid
            mid = (a + b) / 2
            cell_centre = mid.copy()
            cell_centre[axis] = (math.floor(a[axis] / 0.05) + 0.5) * 0.05
            assert w.solid.contains(shapely.Point(cell_centre)), (name, a, b)


@pytest.mark.parametrize("name", SEVEN + ["loop"])
def test_routes_keep_clearance(name):
    """Pure pursuit follows the route: 0.25 m from walls everywhere, no turn over 60 degrees."""
    w = load_world(name)
    path = np.vstack([w.start[:2], w.route])
    line = shapely.LineString(path)
    assert line.distance(w.solid.boundary) >= 0.25
    assert reachable_region(w, 0.25).covers(line)
    seg = np.diff(path, axis=0)
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    turn = np.abs((np.diff(heading) + np.pi) % (2 * np.pi) - np.pi)
    assert np.degrees(turn).max() <= 60


def test_swirl_corridor_widths():
    """The swirl corridors are 0.6 m to 1 m wide: eroding by 0.299 m keeps the free space in
    one piece (every corridor is at least 0.6 m), eroding by 0.32 m cuts it (the narrowest is
    under 0.64 m), and eroding by 0.51 m leaves almost nothing (corridors under 1.02 m;
    only the turning room at the centre is wider)."""
    for n in ("swirl_s", "swirl_m", "swirl_l"):
        f = load_world(n).free_space
        assert isinstance(f.buffer(-0.299), shapely.Polygon)
        assert isinstance(f.buffer(-0.32), shapely.MultiPolygon)
        assert f.buffer(-0.51).area < 0.02 * f.area


def test_obstacles_and_per_polyline_thickness(tmp_path):
    d = _with(obstacles=[{"polygon": [[1.0, 1.0], [1.2, 1.0], [1.1, 1.2]]},
                         {"circle": {"center": [1.5, 1.0], "radius": 0.1}},
                         {"box": {"center": [0.6, 1.5], "size": [0.4, 0.2], "yaw": 0.5}}])
    d["walls"]["polylines"].append({"points": [[1.0, 2.0], [1.0, 1.6]], "thickness": 0.05})
    w = load_world(_write(tmp_path, d, "ok.yaml"))
    assert [o.kind for o in w.obstacles] == ["polygon", "circle", "box"]
    assert w.obstacles[1].polygon.area == pytest.approx(math.pi * 0.01, rel=1e-3)
    assert w.obstacles[2].polygon.area == pytest.approx(0.08)
    assert w.walls[1].thickness == 0.05 and w.walls[0].thickness == 0.12
    assert w.source.endswith("ok.yaml")


def test_defaults(tmp_path):
    d = _with()
    del d["name"], d["route"]
    d["walls"] = {"polylines": d["walls"]["polylines"]}
    w = load_world(_write(tmp_path, d, "plain.yaml"))
    assert w.name == "plain" and w.route is None and w.resolution == 0.05
    assert w.walls[0].thickness == 0.10


def test_yaw_wrapped(tmp_path):
    w = load_world(_write(tmp_path, _with(robot={"start": [0.5, 0.5, 4.0]}), "y.yaml"))
    assert w.start[2] == pytest.approx(4.0 - 2 * math.pi)


# --- one test per bad-world case: the message names the file and the field --------------

def _error(tmp_path, data):
    with pytest.raises(InputError) as e:
        load_world(_write(tmp_path, data))
    msg = str(e.value)
    assert "bad.yaml" in msg
    return msg


def test_circle_with_sides_is_a_regular_polygon(tmp_path):
    d = _with(obstacles=[{"circle": {"center": [1.5, 1.0], "radius": 0.1, "sides": 20}}])
    poly = load_world(_write(tmp_path, d, "ok.yaml")).obstacles[0].polygon
    assert len(poly.exterior.coords) == 21
    assert poly.area == pytest.approx(0.5 * 20 * 0.01 * math.sin(2 * math.pi / 20))
    for bad in (7, 2.5, True, 361, 100_000_000):
        d = _with(obstacles=[{"circle": {"center": [1.5, 1.0], "radius": 0.1, "sides": bad}}])
        assert ("bad.yaml: obstacles[0].circle.sides: expected an integer from 8 to 360"
                in _error(tmp_path, d))


def test_unknown_top_key(tmp_path):
    d = _with()
    d["rout"] = d.pop("route")
    assert "bad.yaml: rout: unknown key (did you mean 'route'?)" in _error(tmp_path, d)


def test_unknown_nested_key(tmp_path):
    d = _with(walls={"thicknes": 0.1, "polylines": GOOD["walls"]["polylines"]})
    assert "bad.yaml: walls.thicknes: unknown key (did you mean 'thickness'?)" in _error(tmp_path, d)
    d = _with(obstacles=[{"circle": {"centre": [1, 1], "radius": 0.1}}])
    assert "bad.yaml: obstacles[0].circle.centre: unknown key (did you mean 'center'?)" in _error(tmp_path, d)
    d = _with(robot={"star": [0.5, 0.5, 0]})
    assert "bad.yaml: robot.star: unknown key (did you mean 'start'?)" in _error(tmp_path, d)


def test_non_numeric_point(tmp_path):
    d = _with()
    d["walls"]["polylines"].append([[0.5, 1.0], [1.0, "a"]])
    assert "bad.yaml: walls.polylines[1][1]: expected a point [x, y], got [1.0, 'a']" in _error(tmp_path, d)
    d = _with(route=[[1.5, 0.5], "x"])
    assert "bad.yaml: route[1]: expected a point [x, y], got 'x'" in _error(tmp_path, d)


def test_wrong_types(tmp_path):
    assert "bad.yaml: walls.thickness: expected a number, got 'thick'" in _error(
        tmp_path, _with(walls={"thickness": "thick", "polylines": GOOD["walls"]["polylines"]}))
    assert "bad.yaml: robot.start: expected a pose [x, y, yaw], got [0.5, 0.5]" in _error(
        tmp_path, _with(robot={"start": [0.5, 0.5]}))
    assert "bad.yaml: resolution: must be positive, got -0.05" in _error(tmp_path, _with(resolution=-0.05))
    assert "bad.yaml: obstacles[0].circle.radius: expected a number, got None" in _error(
        tmp_path, _with(obstacles=[{"circle": {"center": [1, 1], "radius": None}}]))
    assert "bad.yaml: top level: expected a mapping" in _error(tmp_path, "- just\n- a list\n")


def test_too_few_points(tmp_path):
    d = _with()
    d["walls"]["polylines"].append([[1.0, 1.0]])
    assert "bad.yaml: walls.polylines[1]: expected at least 2 points, got 1" in _error(tmp_path, d)
    d = _with(obstacles=[{"polygon": [[1, 1], [1.2, 1]]}])
    assert "bad.yaml: obstacles[0].polygon: expected at least 3 points, got 2" in _error(tmp_path, d)


def test_missing_fields(tmp_path):
    d = _with()
    del d["robot"]
    assert "bad.yaml: robot: missing required field" in _error(tmp_path, d)
    assert "bad.yaml: walls.polylines: missing required field" in _error(tmp_path, _with(walls={"thickness": 0.1}))


def test_start_inside_wall(tmp_path):
    msg = _error(tmp_path, _with(robot={"start": [1.0, -0.05, 0.0]}))
    assert "bad.yaml: robot.start: inside a wall" in msg


def test_start_within_robot_radius(tmp_path):
    msg = _error(tmp_path, _with(robot={"start": [0.05, 0.5, 0.0]}))
    assert "bad.yaml: robot.start: 0.065 m from a wall, within 0.105 m (the robot radius) of a wall" in msg


def test_route_waypoint_inside_wall(tmp_path):
    msg = _error(tmp_path, _with(route=[[1.5, 0.5], [2.08, 1.0]]))
    assert "bad.yaml: route[1]: (2.08, 1) is inside a wall" in msg


def test_route_waypoint_too_close(tmp_path):
    msg = _error(tmp_path, _with(route=[[1.98, 1.0]]))
    assert "bad.yaml: route[0]: (1.98, 1) not reachable from the start: within 0.105 m" in msg


def test_route_waypoint_in_another_room(tmp_path):
    # a wall across the room: the far half cannot be reached
    d = _with(route=[[1.5, 0.5], [1.0, 1.5]])
    d["walls"]["polylines"].append([[-0.075, 1.0], [2.075, 1.0]])
    msg = _error(tmp_path, d)
    assert "bad.yaml: route[1]: (1, 1.5) not reachable from the start: outside the start's room" in msg


def test_route_waypoint_behind_a_narrow_gap(tmp_path):
    # a gap of 0.15 m (narrower than the robot) joins the two halves: free space, not reachable
    d = _with(route=[[1.0, 1.5]])
    d["walls"]["polylines"].append([[-0.075, 1.0], [1.825, 1.0]])
    msg = _error(tmp_path, d)
    assert "bad.yaml: route[0]: (1, 1.5) not reachable from the start: cut off by a passage" in msg


def test_no_enclosed_free_space(tmp_path):
    d = _with(route=None)
    d["walls"]["polylines"] = [[[-0.075, -0.075], [2.075, -0.075], [2.075, 2.075], [-0.075, 2.075]]]
    assert "bad.yaml: walls: no enclosed free space around the start" in _error(tmp_path, d)


def test_start_outside_the_room(tmp_path):
    d = _with(route=None, robot={"start": [3.0, 3.0, 0.0]})
    assert "bad.yaml: walls: no enclosed free space around the start" in _error(tmp_path, d)


def test_not_yaml_and_missing(tmp_path):
    with pytest.raises(InputError, match=r"bad\.yaml: not valid YAML"):
        load_world(_write(tmp_path, "walls: [\n"))
    with pytest.raises(InputError, match="nope.yaml: file not found"):
        load_world(tmp_path / "nope.yaml")
    with pytest.raises(InputError, match="no_such_world: no such world"):
        load_world("no_such_world")


def test_reachable_region_is_eroded_by_the_robot_radius():
    w = load_world("rectangle_s")
    region = reachable_region(w)
    x0, y0, x1, y1 = region.bounds
    assert x0 == pytest.approx(-0.015 + ROBOT_RADIUS) and x1 == pytest.approx(3.015 - ROBOT_RADIUS)
