"""The name rule and the write fence: a name from a file never leads a write out of its folder.

Each entry point that turns a name from a file into a path is tried with `../x`, `/abs/x`,
`a/b`, `..`, an empty name and unicode; the folders above the output are listed before and
after, and must not change."""
from __future__ import annotations

from pathlib import Path

import pytest

from worlds.paths import MAX_NAME_LENGTH, check_name, is_name, path_inside
from worlds.yamlio import InputError, atomic_write_text

BAD_NAMES = ["../x", "/abs/x", "a/b", "..", "", "wörld", ".hidden", "a b", "x" * 101, "a\\b"]
GOOD_NAMES = ["swirl_l", "office_s3_10x8", "a.b", "v1.2+dev-3", "x" * MAX_NAME_LENGTH]

ROOM = """name: {name}
walls:
  thickness: 0.1
  polylines:
    - [[0, 0], [1.6, 0], [1.6, 1.2], [0, 1.2], [0, 0]]
robot:
  start: [0.4, 0.4, 0]
route:
  - [1.2, 0.4]
  - [0.5, 0.8]
"""


def _listing(root: Path) -> set[str]:
    """Every path under `root` (files and folders), relative."""
    return {str(p.relative_to(root)) for p in root.rglob("*")}


@pytest.mark.parametrize("name", GOOD_NAMES)
def test_names_that_are_accepted(name):
    assert is_name(name) and check_name(name, "f.yaml", "name") == name


@pytest.mark.parametrize("name", BAD_NAMES + [None, 5, ["a"]])
def test_names_that_are_refused_name_the_file_and_the_field(name):
    assert not is_name(name)
    with pytest.raises(InputError, match=r"^f\.yaml: name: ") as err:
        check_name(name, "f.yaml", "name")
    assert "\n" not in str(err.value) and len(str(err.value)) < 300


def test_path_inside_refuses_dot_dot_absolute_and_symlinks_out(tmp_path):
    root = tmp_path / "out"
    (root / "sub").mkdir(parents=True)
    assert path_inside(root, "sub", "a.npz") == root / "sub" / "a.npz"
    assert path_inside("relative/dir", "x") == Path("relative/dir/x")
    for parts in (("..", "x"), ("/etc/passwd",), ("sub", "..", "..", "x")):
        with pytest.raises(InputError, match="outside the folder"):
            path_inside(root, *parts)
    (root / "link").symlink_to(tmp_path)
    with pytest.raises(InputError, match="outside the folder"):
        path_inside(root, "link", "x")


def test_atomic_write_with_a_root_writes_nothing_outside(tmp_path, monkeypatch):
    root = tmp_path / "out"
    root.mkdir()
    before = _listing(tmp_path)
    with pytest.raises(InputError):
        atomic_write_text(root / ".." / "victim.txt", "x", root=root)
    assert _listing(tmp_path) == before
    monkeypatch.chdir(tmp_path)
    atomic_write_text(Path("out") / "a.txt", "ok", root="out")   # relative path and root
    assert (root / "a.txt").read_text() == "ok"


@pytest.mark.parametrize("name", BAD_NAMES)
def test_worlds_render_refuses_a_world_name_that_is_not_a_name(tmp_path, capsys, name):
    from worlds.__main__ import main
    (tmp_path / "in").mkdir()
    world = tmp_path / "in" / "w.yaml"
    world.write_text(ROOM.format(name=repr(name) if name else "''"))
    before = _listing(tmp_path)
    assert main(["render", str(world), "--out", str(tmp_path / "in" / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "w.yaml: name: " in err[0]
    assert _listing(tmp_path) == before


@pytest.mark.parametrize("name", ["../../../X", "/abs/x", "a/b", ".."])
def test_bench_run_refuses_a_world_name_before_any_write(tmp_path, capsys, monkeypatch, name):
    from bench.__main__ import main
    (tmp_path / "a" / "b").mkdir(parents=True)
    cache = tmp_path / "cache"
    cache.mkdir()
    monkeypatch.setenv("SLAM_BENCH_CACHE", str(cache))
    world = tmp_path / "w.yaml"
    world.write_text(ROOM.format(name=repr(name)))
    before, cached = _listing(tmp_path), _listing(cache)
    assert main(["run", "--world", str(world), "--algo", "oracle", "--repeats", "1",
                 "--out", str(tmp_path / "a" / "b" / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "w.yaml: name: " in err[0]
    outside = {p for p in _listing(tmp_path) if not p.startswith("a/b/out")}
    assert outside == before and _listing(cache) == cached


@pytest.mark.parametrize("name", BAD_NAMES)
def test_an_algorithm_name_follows_the_rule(name):
    from slam.registry import register
    with pytest.raises(InputError, match="name: "):
        register(name)
