"""Resource bounds (worlds.limits): a grid or a route planner that would take gigabytes is
refused before it allocates, with one line naming the cause and how to raise the bound."""
import time

import numpy as np
import pytest

from worlds.__main__ import main as worlds_main
from worlds.load import world_from_dict
from worlds.raster import rasterize
from worlds.route import route_for
from worlds.yamlio import InputError, dump_yaml

ROOM = {"walls": {"polylines": [[[0, 0], [3, 0], [3, 2], [0, 2], [0, 0]]]},
        "robot": {"start": [1, 1, 0]}, "route": [[1, 1], [2, 1]]}


def test_a_fine_resolution_is_refused_before_allocating(tmp_path, capsys):
    """resolution 0.0001 on a 3 m x 2 m room took 18.7 GB before."""
    world = world_from_dict({**ROOM, "resolution": 0.0001}, where="fine.yaml")
    t0 = time.perf_counter()
    with pytest.raises(InputError, match=r"fine.yaml: resolution: 0.0001 m over .* needs a grid of .* "
                                         r"cells, more than the limit of 20,000,000 .*SLAM_BENCH_MAX_CELLS"):
        rasterize(world)
    assert time.perf_counter() - t0 < 5
    path = tmp_path / "fine.yaml"
    path.write_text(dump_yaml({**ROOM, "resolution": 0.0001}))
    assert worlds_main(["render", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "SLAM_BENCH_MAX_CELLS" in err[0]


def test_the_limit_can_be_raised(monkeypatch):
    world = world_from_dict({**ROOM, "resolution": 0.001}, where="fine.yaml")   # 6 million cells
    monkeypatch.setenv("SLAM_BENCH_MAX_CELLS", "1e6")
    with pytest.raises(InputError, match="limit of 1,000,000"):
        rasterize(world)
    monkeypatch.setenv("SLAM_BENCH_MAX_CELLS", "1e7")
    assert rasterize(world).prob.size > 1e6


def test_a_huge_world_without_a_route_is_refused_by_the_planner():
    """A 200 m x 200 m world without a route passed 6 GB in the route planner before."""
    world = world_from_dict({"walls": {"polylines": [[[0, 0], [200, 0], [200, 200], [0, 200], [0, 0]]]},
                             "robot": {"start": [1, 1, 0]}}, where="huge.yaml")
    t0 = time.perf_counter()
    with pytest.raises(InputError, match=r"huge.yaml: route: the free space is about .* cells, .*give "
                                         r"the world a route"):
        route_for(world)
    assert time.perf_counter() - t0 < 5


def test_a_slam_map_does_not_grow_without_bound():
    """A pose 100 km off made graph and the oracle allocate terabytes before."""
    from slam.occupancy import LogOddsGrid
    grid = LogOddsGrid(0.05, (0.0, 0.0))
    with pytest.raises(InputError, match=r"map: a point at .* \(a pose far off\) needs a grid of"):
        grid.insert_scan(np.array([0.0, 0.0]), np.array([[1e5, 0.0]]))


def test_a_map_file_claiming_a_huge_image_is_refused_before_reading(tmp_path):
    from worlds.mapio import read_pgm
    p = tmp_path / "big.pgm"
    p.write_bytes(b"P5\n100000 100000\n255\n" + bytes(10))
    with pytest.raises(InputError, match="big.pgm: a 100000 x 100000 image needs a grid"):
        read_pgm(p)
