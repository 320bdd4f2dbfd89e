"""worlds.generate: every kind loads and its route sees the walls, same arguments give the same
bytes, wall faces land on and off cell edges, bad arguments give one line (exit 2 on the CLI)."""
import re

import numpy as np
import pytest
import shapely
import yaml

import worlds.generate as gen
from worlds.__main__ import main
from worlds.coverage import resample_path, wall_coverage
from worlds.generate import DEFAULT_SIZE, KINDS, MIN_SIZE, generate_world, generate_yaml, parse_size
from worlds.load import load_world, world_from_dict
from worlds.model import ROBOT_RADIUS
from worlds.yamlio import InputError

# small enough to keep the module fast, big enough for every recipe step (two room rows
# aside: the office at 6 x 5 has rooms on one side of its corridor)
SMALL = {"office": (6.0, 5.0), "warehouse": (7.0, 5.0), "hall": (5.0, 4.0), "loop": (8.0, 5.0)}


def _load(text: str):
    return world_from_dict(yaml.safe_load(text), where="generated")


def _path(world) -> np.ndarray:
    return np.vstack([world.start[:2], world.route])


@pytest.fixture(scope="module")
def small():
    """kind -> YAML text of seed 0 at the SMALL size."""
    return {kind: generate_yaml(kind, 0, size) for kind, size in SMALL.items()}


@pytest.mark.parametrize("kind", KINDS)
def test_small_worlds_load_and_their_routes_see_the_walls(small, kind):
    w = _load(small[kind])
    assert w.name == f"{kind}_s0_{SMALL[kind][0]:g}x{SMALL[kind][1]:g}"
    assert w.route is not None and len(w.route) >= 2
    assert wall_coverage(w, _path(w), max_range=3.5) >= 0.95


@pytest.mark.parametrize("kind", KINDS)
def test_same_arguments_same_bytes_other_seed_other_world(small, kind):
    assert generate_yaml(kind, 0, SMALL[kind]) == small[kind]
    assert generate_yaml(kind, 1, SMALL[kind]) != small[kind]


def test_generate_yaml_is_generate_world_written():
    data = generate_world("loop", 3, SMALL["loop"])
    assert yaml.safe_load(generate_yaml("loop", 3, SMALL["loop"])) == data
    assert list(data) == ["name", "description", "resolution", "walls", "obstacles", "robot", "route"]
    assert data["resolution"] == 0.05 and 0.10 <= data["walls"]["thickness"] <= 0.15


def test_yaml_is_compact_and_in_mm(small):
    text = small["office"]
    assert re.search(r"^  - \[\[", text, re.M)              # a polyline on one flow line
    assert re.search(r"^- \{(box|polygon): ", text, re.M)     # an obstacle on one flow line
    assert re.search(r"^- \[-?[\d.]+, -?[\d.]+\]$", text, re.M)  # one waypoint per line
    numbers = re.findall(r"-?\d+\.\d+", text.split("\nwalls:", 1)[1])
    assert numbers and all(len(n.split(".")[1]) <= 3 for n in numbers)


def test_default_size_gives_the_short_name():
    assert generate_world("loop", 0, DEFAULT_SIZE["loop"])["name"] == "loop_s0"
    assert generate_world("loop", 0, (8, 5))["name"] == "loop_s0_8x5"


def test_loop_route_closes_at_its_start_and_keeps_clear_of_walls():
    kinds = set()
    for seed in range(4):
        w = _load(generate_yaml("loop", seed, SMALL["loop"]))
        np.testing.assert_array_equal(w.route[-1], w.start[:2])
        clear = shapely.distance(w.solid, shapely.points(resample_path(_path(w), 0.05)))
        assert clear.min() >= ROBOT_RADIUS + 0.1
        kinds.add("figure eight" in w.description)
    assert kinds == {True, False}, "seeds 0-3 should draw both one ring and a figure eight"


def test_wall_faces_on_and_off_cell_edges(small):
    coords = []
    for text in small.values():
        s = _load(text).segments
        coords += [s[s[:, 0] == s[:, 2], 0], s[s[:, 1] == s[:, 3], 1]]
    c = np.concatenate(coords)
    k = c / 0.05
    on_edge = np.abs(k - np.round(k)) < 1e-9
    assert on_edge.any(), "no axis-aligned face exactly on a cell edge"
    assert on_edge.mean() < 0.5, f"{on_edge.mean():.2f} of the faces on cell edges"


@pytest.mark.parametrize("kind", KINDS)
def test_minimum_size_generates(kind):
    w = _load(generate_yaml(kind, 0, MIN_SIZE[kind]))
    assert wall_coverage(w, _path(w), max_range=3.5) >= 0.95


def test_a_failing_draw_is_replaced_by_the_next_one(monkeypatch):
    first = generate_world("loop", 5, SMALL["loop"])
    real, calls = gen._checked, []

    def reject_first(data):
        calls.append(data["description"])
        if len(calls) == 1:
            raise gen.Rejected("test")
        return real(data)

    monkeypatch.setattr(gen, "_checked", reject_first)
    second = generate_world("loop", 5, SMALL["loop"])
    assert second != first and calls[0] == first["description"]
    calls.clear()
    assert generate_world("loop", 5, SMALL["loop"]) == second


def test_no_passing_draw_is_a_one_line_error(monkeypatch):
    monkeypatch.setattr(gen, "MAX_DRAWS", 2)
    monkeypatch.setattr(gen, "MIN_COVERAGE", 1.01)
    with pytest.raises(InputError, match=r"^loop seed 0: none of 2 draws passed the checks \(last: "
                                         r"the route sees") as err:
        generate_world("loop", 0, SMALL["loop"])
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("kind,seed,size,msg", [
    ("ofice", 0, None, "kind: unknown kind 'ofice', expected one of office, warehouse, hall, loop "
                       "(did you mean 'office'?)"),
    ("maze", 0, None, "kind: unknown kind 'maze', expected one of office, warehouse, hall, loop"),
    ("office", -1, None, "seed: expected a non-negative integer, got -1"),
    ("office", 1.5, None, "seed: expected a non-negative integer, got 1.5"),
    ("office", 0, (4, 4), "size: 4 x 4 m is too small for kind office (minimum 5 x 4 m)"),
    ("loop", 0, (12, 3.9), "size: 12 x 3.9 m is too small for kind loop (minimum 4.5 x 4 m)"),
    ("hall", 0, (0, 7), "size: must be positive, got 0 x 7"),
    ("hall", 0, (9, -7), "size: must be positive, got 9 x -7"),
    ("hall", 0, (9,), "size: expected (W, H) in metres, got (9,)"),
])
def test_bad_arguments(kind, seed, size, msg):
    with pytest.raises(InputError) as err:
        generate_world(kind, seed, size)
    assert str(err.value) == msg


@pytest.mark.parametrize("text,size", [("10x8", (10.0, 8.0)), (" 10.5X7.25 ", (10.5, 7.25)),
                                       ("6 x 5", (6.0, 5.0))])
def test_parse_size(text, size):
    assert parse_size(text) == size


@pytest.mark.parametrize("text", ["10by8", "10x", "x8", "10x8x2", ""])
def test_parse_size_rejects(text):
    with pytest.raises(InputError, match=r"^--size: expected WxH in metres \(e\.g\. 10x8\), got "):
        parse_size(text)


def test_cli_writes_a_world_that_loads(tmp_path, capsys):
    out = tmp_path / "new" / "folder" / "w.yaml"
    assert main(["generate", "loop", "--seed", "2", "--size", "8x5", "--out", str(out)]) == 0
    line = capsys.readouterr().out
    assert line.startswith(f"{out}: loop_s2_8x5: ") and line.count("\n") == 1
    assert re.search(r"\d+ walls \(.* m\), 0 obstacles, route [\d.]+ m \(\d+ waypoints\)", line)
    assert out.read_text() == generate_yaml("loop", 2, (8, 5))
    w = load_world(out)
    assert w.name == "loop_s2_8x5" and w.route is not None
    assert not list(out.parent.glob(".*.tmp"))


@pytest.mark.parametrize("argv,msg", [
    (["generate", "office", "--seed", "0", "--size", "10by8"], "error: --size: expected WxH in metres"),
    (["generate", "ofice", "--seed", "0"], "error: kind: unknown kind 'ofice'"),
    (["generate", "office", "--seed", "-3"], "error: --seed: must be an integer >= 0, got '-3'"),
    (["generate", "office", "--seed", "0", "--size", "3x3"], "error: size: 3 x 3 m is too small"),
    (["generate", "office", "--seed", "0", "--size", "0x8"], "error: size: must be positive"),
])
def test_cli_bad_input_one_line_exit_2(tmp_path, argv, msg, capsys):
    out = tmp_path / "w.yaml"
    assert main(argv + ["--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(msg) and err.count("\n") == 1
    assert not out.exists()


def test_cli_out_must_be_a_yaml_file(tmp_path, capsys):
    assert main(["generate", "loop", "--seed", "0", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith("error: --out: expected a .yaml file")


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_default_size_seed_0(kind):
    w = _load(generate_yaml(kind, 0))
    assert w.name == f"{kind}_s0"
    assert wall_coverage(w, _path(w), max_range=3.5) >= 0.95
