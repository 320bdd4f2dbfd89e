"""Hostile input for every reader: random byte damage, NaN / inf / negative values and wrong
field types thrown at world YAML, map YAML and PGM, sensor logs, TUM trajectories, relations
files, CARMEN logs and config YAML, each through its command line. Every example must end with
exit code 0 or 2, at most one line on stderr, no traceback and no half-written file."""
from __future__ import annotations

import io
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from metrics.__main__ import main as metrics_main
from sim.__main__ import main as sim_main
from sim.logs import write_log
from slam.__main__ import main as slam_main
from tests.rawlog import raw_npz_bytes
from tests.slam.synthlog import box_room_segments, make_log
from worlds.__main__ import main as worlds_main

DATA = Path(__file__).resolve().parents[1] / "data"
EXAMPLES = 150
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

ROOM = """name: room
walls:
  thickness: 0.1
  polylines:
    - [[0, 0], [3, 0], [3, 2], [0, 2], [0, 0]]
obstacles:
  - {box: {center: [1.5, 1.0], size: [0.3, 0.3], yaw: 0.2}}
robot:
  start: [0.6, 0.6, 0.0]
route:
  - [2.4, 0.6]
"""
CONFIG = "map_multi_res_levels: 2\nprior_yaw_weight: 30.0\npreprocess: {smooth_beams: 2, range_max: 3.0}\n"
HOSTILE = ["nan", ".nan", ".inf", "-.inf", "-1", "-1e308", "1e308", "0", "true", "null", "[]", "{}",
           "'x'", "[1, 2]", "{a: 1}"]


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    """One valid file of each kind."""
    d = tmp_path_factory.mktemp("good")
    (d / "room.yaml").write_text(ROOM)
    assert worlds_main(["render", str(d / "room.yaml"), "--out", str(d / "gt")]) == 0
    log = make_log(box_room_segments(), np.array([[1.0, 1.0], [2.0, 1.0]]), seed=6)
    write_log(log, d / "log.npz")
    assert slam_main(["run", "--algo", "oracle", "--log", str(d / "log.npz"), "--out", str(d / "run"),
                      "--quiet"]) == 0
    (d / "gn.yaml").write_text(CONFIG)
    return d


def _damage_bytes(data: bytes, draw) -> bytes:
    """Truncate, overwrite, insert or delete a few bytes."""
    if not data:
        return draw(st.binary(max_size=64))
    op = draw(st.sampled_from(["truncate", "overwrite", "insert", "delete"]))
    k = draw(st.integers(0, len(data) - 1))
    junk = draw(st.binary(min_size=1, max_size=16))
    if op == "truncate":
        return data[:k]
    if op == "overwrite":
        return data[:k] + junk + data[k + len(junk):]
    if op == "insert":
        return data[:k] + junk + data[k:]
    return data[:k] + data[k + len(junk):]


def _damage_values(text: str, draw) -> str:
    """Replace one number (or word) of a YAML/text file by a hostile value."""
    tokens = list(re.finditer(r"-?\d+(\.\d+)?(e-?\d+)?|\b[a-z_]+\b", text))
    if not tokens:
        return text
    m = tokens[draw(st.integers(0, len(tokens) - 1))]
    return text[:m.start()] + draw(st.sampled_from(HOSTILE)) + text[m.end():]


def _damaged_text(draw, text: str) -> bytes:
    if draw(st.booleans()):
        return _damage_values(text, draw).encode()
    return _damage_bytes(text.encode(), draw)


def _run(main, argv, capsys, out: Path | None = None) -> None:
    """Run a CLI on damaged input: exit 0 or 2, one line at most on stderr, nothing half-written."""
    try:
        code = main(argv)
    except SystemExit as exc:   # argparse
        code = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code in (0, 2), (code, err)
    assert len(err) <= 1, err
    assert not any("Traceback" in line for line in err)
    if code == 2:
        assert err and err[0].startswith("error: "), err
    if out is not None and out.exists():
        leftovers = [p.name for p in out.rglob("*") if p.name.endswith(".tmp") or ".tmp." in p.name]
        assert not leftovers, leftovers


def _fresh(tmp_path: Path, name: str) -> Path:
    d = tmp_path / name
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True)
    return d


@FUZZ
@given(data=st.data())
def test_world_yaml(good, tmp_path, capsys, data):
    d = _fresh(tmp_path, "w")
    (d / "w.yaml").write_bytes(_damaged_text(data.draw, ROOM))
    _run(worlds_main, ["render", str(d / "w.yaml"), "--out", str(d / "out")], capsys, d / "out")


@FUZZ
@given(data=st.data())
def test_map_yaml_and_pgm(good, tmp_path, capsys, data):
    d = _fresh(tmp_path, "m")
    src = good / "run"
    text = (src / "map.yaml").read_text()
    if data.draw(st.booleans()):
        (d / "map.yaml").write_bytes(_damaged_text(data.draw, text))
        shutil.copy(src / "map.pgm", d / "map.pgm")
    else:
        (d / "map.yaml").write_text(text)
        (d / "map.pgm").write_bytes(_damage_bytes((src / "map.pgm").read_bytes(), data.draw))
    _run(metrics_main, ["score", "--map", str(d / "map.yaml"), "--truth", str(good / "gt" / "room.yaml"),
                        "--json"], capsys)


def _damaged_log(good: Path, draw) -> bytes:
    raw = (good / "log.npz").read_bytes()
    kind = draw(st.sampled_from(["bytes", "value", "meta"]))
    if kind == "bytes":
        return _damage_bytes(raw, draw)
    with np.load(io.BytesIO(raw)) as npz:
        arrays = {k: np.array(npz[k]) for k in npz.files if k != "meta"}
        meta = json.loads(str(np.asarray(npz["meta"]).reshape(-1)[0]))
    if kind == "value":
        name = draw(st.sampled_from(sorted(arrays)))
        a = arrays[name].astype(np.float64)
        if a.size:
            a.reshape(-1)[draw(st.integers(0, a.size - 1))] = draw(
                st.sampled_from([np.nan, np.inf, -np.inf, -1.0, 1e300, -1e300]))
        arrays[name] = a
    else:
        key = draw(st.sampled_from(["format_version", "lidar", "start_pose", "seed", "world"]))
        meta[key] = draw(st.sampled_from([None, "x", -3, 0, True, [], {}, [1.0, "a"], 1e308]))
    return raw_npz_bytes(arrays, meta)


@FUZZ
@given(data=st.data())
def test_sensor_log(good, tmp_path, capsys, data):
    d = _fresh(tmp_path, "l")
    (d / "log.npz").write_bytes(_damaged_log(good, data.draw))
    _run(slam_main, ["run", "--algo", "oracle", "--log", str(d / "log.npz"), "--out", str(d / "out"),
                     "--quiet"], capsys, d / "out")


@FUZZ
@given(data=st.data())
def test_tum_trajectory(good, tmp_path, capsys, data):
    d = _fresh(tmp_path, "t")
    (d / "t.tum").write_bytes(_damaged_text(data.draw, (good / "run" / "trajectory.tum").read_text()))
    _run(metrics_main, ["trajectory", "--est", str(d / "t.tum"), "--truth", str(good / "log.npz"), "--json"],
         capsys)


@FUZZ
@given(data=st.data())
def test_relations_file(good, tmp_path, capsys, data):
    d = _fresh(tmp_path, "r")
    (d / "r.relations").write_bytes(_damaged_text(data.draw, (DATA / "mit-csail_excerpt.relations").read_text()))
    t = np.loadtxt(DATA / "mit-csail_excerpt.relations")[:, :2].reshape(-1)
    t = np.unique(t)
    (d / "t.tum").write_text("".join(f"{x:.6f} {0.1 * i:.3f} 0 0 0 0 0 1\n" for i, x in enumerate(t)))
    _run(metrics_main, ["relations", "--traj", str(d / "t.tum"), "--relations", str(d / "r.relations"),
                        "--json"], capsys)


@FUZZ
@given(data=st.data())
def test_carmen_log(good, tmp_path, capsys, data):
    d = _fresh(tmp_path, "c")
    (d / "c.log").write_bytes(_damaged_text(data.draw, (DATA / "carmen_fr079_head.log").read_text()))
    _run(sim_main, ["import", str(d / "c.log"), "--out", str(d / "out" / "c.npz")], capsys, d / "out")


@FUZZ
@given(data=st.data())
def test_config_yaml(good, tmp_path, capsys, data):
    d = _fresh(tmp_path, "y")
    (d / "gn.yaml").write_bytes(_damaged_text(data.draw, CONFIG))
    _run(slam_main, ["run", "--algo", "gn", "--log", str(good / "log.npz"), "--config", str(d / "gn.yaml"),
                     "--out", str(d / "out"), "--quiet"], capsys, d / "out")
