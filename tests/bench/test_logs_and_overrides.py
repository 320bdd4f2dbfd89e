"""`bench run --logs DIR` runs on recorded logs as they are; `--set ALGO.FIELD=VALUE` overrides
one config field."""
import json
import shutil
from pathlib import Path

import pytest

import sim
import worlds
from bench.__main__ import main
from tests.bench.conftest import TINY


@pytest.fixture(scope="module")
def log_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    from tests.bench.conftest import TINY
    shutil.copy(TINY, d)   # a log's world is read from the log's folder (or the shipped ones)
    world = worlds.load_world(d / Path(TINY).name)
    for seed in (3, 5):
        sim.write_log(sim.record(world, seed=seed), d / f"tiny_{seed}.npz")
    return d


def _rows(out):
    data = json.loads((out / "results.json").read_text())
    return data["rows"] if isinstance(data, dict) else data


def test_logs_are_run_as_given_and_nothing_is_recorded(log_dir, tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("SLAM_BENCH_CACHE", str(cache))
    out = tmp_path / "run"
    assert main(["run", "--logs", str(log_dir), "--algo", "fake_map", "--repeats", "2", "--jobs", "1",
                 "--no-figures", "--no-progress", "--out", str(out)]) == 0
    rows = _rows(out)
    assert sorted((r["log_seed"], r["draw"], r["repeat"]) for r in rows) == \
        [(3, 0, 0), (3, 0, 1), (5, 1, 2), (5, 1, 3)]
    assert all(r["status"] == "ok" and r["world"] == "tiny" for r in rows)
    assert not list(cache.glob("*.npz"))
    assert main(["run", "--resume", str(out), "--jobs", "1", "--no-figures", "--no-progress"]) == 0


def test_a_log_whose_world_is_unknown_is_one_line_error(log_dir, tmp_path, capsys):
    log = sim.read_log(log_dir / "tiny_3.npz")
    log.meta.update(world="nowhere", world_source="nowhere.yaml")
    sim.write_log(log, tmp_path / "lost.npz")
    assert main(["run", "--logs", str(tmp_path / "lost.npz"), "--algo", "fake_map",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "lost.npz: meta.world" in err[0]


def test_a_log_never_leads_to_a_world_file_outside_its_folder(log_dir, tmp_path, capsys):
    """A stranger's log names a world YAML elsewhere on the machine: it is not read."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    shutil.copy(log_dir / Path(TINY).name, elsewhere / "w.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    log = sim.read_log(log_dir / "tiny_3.npz")
    log.meta.update(world="w", world_source=str(elsewhere / "w.yaml"))
    sim.write_log(log, logs / "a.npz")
    log.meta.update(world_source="../elsewhere/w.yaml")
    sim.write_log(log, logs / "b.npz")
    for name in ("a.npz", "b.npz"):
        assert main(["run", "--logs", str(logs / name), "--algo", "fake_map",
                     "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{name}: meta.world" in err[0] and "copy its YAML" in err[0]
    shutil.copy(elsewhere / "w.yaml", logs / "w.yaml")   # beside the log: read
    assert sim.logs.world_ref(sim.read_log(logs / "a.npz").meta, logs / "a.npz") == str(
        (logs / "w.yaml").resolve())


def test_set_overrides_one_field_and_is_checked(log_dir, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--logs", str(log_dir / "tiny_3.npz"), "--algo", "fake_map", "--repeats", "1",
                 "--jobs", "1", "--no-figures", "--no-progress", "--out", str(out),
                 "--set", "fake_map.pose_noise_m=0.25"]) == 0
    run = json.loads((out / "run.json").read_text())
    assert run["configs"]["fake_map"]["pose_noise_m"] == 0.25
    capsys.readouterr()
    for bad, msg in (("fake_map.pose_noise=1", "pose_noise: unknown key"),
                     ("fake_map=1", "ALGO.FIELD=VALUE"),
                     ("gn.map_resolution=0.1", "not in this run"),
                     ("fake_map.pose_noise_m=[1, 2", "YAML")):
        assert main(["run", "--world", str(log_dir.parent), "--algo", "fake_map", "--set", bad,
                     "--out", str(tmp_path / "x")]) == 2
        err = capsys.readouterr().err
        assert msg in err and len(err.strip().splitlines()) == 1, (bad, err)
