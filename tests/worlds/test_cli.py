"""python -m worlds: list, show, render; bad input gives one line and exit 2."""
import subprocess
import sys

import numpy as np
import pytest

from worlds.__main__ import main
from worlds.load import load_world
from worlds.mapio import read_map
from worlds.raster import rasterize


def test_list(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[0] == "name"
    rows = {line.split()[0]: line for line in out[1:]}
    assert {"rectangle_s", "swirl_l", "corridor", "loop"} <= set(rows)
    assert "3.03 x  2.03" in rows["rectangle_s"] and "waypoints" in rows["swirl_l"]


def test_render_writes_the_truth_pair(tmp_path, capsys):
    assert main(["render", "swirl_s", "--out", str(tmp_path / "gt")]) == 0
    yp = tmp_path / "gt" / "swirl_s.yaml"
    assert yp.is_file() and (tmp_path / "gt" / "swirl_s.pgm").is_file()
    assert read_map(yp).equals(rasterize(load_world("swirl_s")))


def test_render_a_file_with_resolution_and_png(tmp_path):
    assert main(["render", "tests/data/worlds_obstacles.yaml", "--out", str(tmp_path),
                 "--resolution", "0.1", "--png"]) == 0
    g = read_map(tmp_path / "worlds_obstacles.yaml")
    assert g.resolution == 0.1
    assert (tmp_path / "worlds_obstacles.png").stat().st_size > 1000


def test_render_png_map_image(tmp_path, capsys):
    assert main(["render", "swirl_s", "--out", str(tmp_path), "--image-format", "png"]) == 0
    assert capsys.readouterr().out.strip().endswith("swirl_s.yaml + swirl_s.png")
    assert not (tmp_path / "swirl_s.pgm").exists()
    assert read_map(tmp_path / "swirl_s.yaml").equals(rasterize(load_world("swirl_s")))
    assert main(["render", "swirl_s", "--out", str(tmp_path), "--image-format", "png", "--png"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--png draws DIR/NAME.png" in err[0]


def test_show(tmp_path):
    out = tmp_path / "s.png"
    assert main(["show", "rectangle_s", "--out", str(out)]) == 0
    assert out.read_bytes()[:4] == b"\x89PNG"
    out2 = tmp_path / "o.png"
    assert main(["show", "tests/data/worlds_obstacles.yaml", "--out", str(out2)]) == 0
    assert out2.stat().st_size > 1000


@pytest.mark.parametrize("argv,msg", [
    (["show", "no_such_world"], "error: no_such_world: no such world"),
    (["render", "missing.yaml", "--out", "x"], "error: missing.yaml: file not found"),
    (["render", "rectangle_s", "--out", "x", "--resolution", "0"], "error: --resolution: must be positive"),
    (["render", "rectangle_s", "--out", "x", "--resolution", "nan"],
     "error: --resolution: expected a finite"),
])
def test_bad_input_one_line_exit_2(argv, msg, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(msg) and err.count("\n") == 1


def test_bad_world_file(tmp_path, capsys):
    p = tmp_path / "w.yaml"
    p.write_text("walls: {polylines: [[[0, 0], [1, 'a']]]}\nrobot: {start: [0.5, 0.5, 0]}\n")
    assert main(["render", str(p), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err == f"error: {p}: walls.polylines[0][1]: expected a point [x, y], got [1, 'a']\n"


def test_module_entry_point(tmp_path):
    r = subprocess.run([sys.executable, "-m", "worlds", "render", "nope", "--out", str(tmp_path)],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.startswith("error: nope: no such world")


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """A folder holding two small generated worlds."""
    d = tmp_path_factory.mktemp("generated")
    for kind, seed in (("loop", 0), ("hall", 1)):
        out = d / f"{kind}.yaml"
        assert main(["generate", kind, "--seed", str(seed), "--size", "5x4", "--out", str(out)]) == 0
    return d


def test_list_files_and_folders(generated, capsys):
    capsys.readouterr()
    assert main(["list", str(generated), str(generated / "loop.yaml")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[0] == "file"
    files = [line.split()[0] for line in out[1:]]
    assert files == [str(generated / "hall.yaml"), str(generated / "loop.yaml"), str(generated / "loop.yaml")]
    assert all("waypoints" in line for line in out[1:])


@pytest.mark.parametrize("make,msg", [
    (lambda d: d / "nope.yaml", "no such file or folder"),
    (lambda d: d, "no .yaml files in this folder"),
])
def test_list_bad_path_one_line_exit_2(tmp_path, make, msg, capsys):
    assert main(["list", str(make(tmp_path))]) == 2
    err = capsys.readouterr().err
    assert err == f"error: {make(tmp_path)}: {msg}\n"


def test_show_and_render_a_generated_world(generated, tmp_path):
    png = tmp_path / "hall.png"
    assert main(["show", str(generated / "hall.yaml"), "--out", str(png)]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert main(["render", str(generated / "hall.yaml"), "--out", str(tmp_path)]) == 0
    assert read_map(tmp_path / "hall_s1_5x4.yaml").equals(rasterize(load_world(generated / "hall.yaml")))


@pytest.mark.parametrize("where, problem", [("file", "--out must be a folder, this is a file"),
                                            ("under_file", "Not a directory"),
                                            ("read_only", "Permission denied")])
def test_render_into_a_folder_that_cannot_be_written(request, capsys, where, problem):
    out = {"file": lambda: request.getfixturevalue("a_file"),
           "under_file": lambda: request.getfixturevalue("a_file") / "gt",
           "read_only": lambda: request.getfixturevalue("read_only_dir") / "gt"}[where]()
    assert main(["render", "rectangle_s", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {out}: {problem}") and err.count("\n") == 1


def test_ctrl_c_at_start_up(interrupted_main, capsys):
    import worlds.__main__
    assert interrupted_main(worlds.__main__, ["list"]) == 130
    assert capsys.readouterr().err == "interrupted\n"
