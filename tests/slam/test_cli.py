"""python -m slam: run writes the result files; bad input gives one line and exit 2."""
import numpy as np
import pytest

from sim.logs import SensorLog, write_log
from slam.__main__ import main

from tests.slam.synthlog import box_room_segments, make_log


@pytest.fixture(scope="module")
def short_log(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    log = make_log(box_room_segments(), np.array([[1.0, 1.0], [3.0, 1.0]]), 0.0, seed=4)
    write_log(log, d / "room.npz")
    empty = SensorLog(np.zeros(0), np.zeros((0, 360)), log.scan_angles, meta=log.meta)
    write_log(empty, d / "empty.npz")
    inf = SensorLog(**{**log.__dict__, "scan_ranges": np.full_like(log.scan_ranges, np.inf)})
    write_log(inf, d / "inf.npz")
    return d


@pytest.mark.parametrize("algo", ["gn", "oracle"])
def test_run_writes_the_files(short_log, tmp_path, algo, capsys):
    assert main(["run", "--algo", algo, "--log", str(short_log / "room.npz"), "--out", str(tmp_path / "o")]) == 0
    names = sorted(p.name for p in (tmp_path / "o").iterdir())
    assert names == ["config.yaml", "map.pgm", "map.yaml", "stats.json", "trajectory.tum"]
    assert "real time" in capsys.readouterr().out


def test_list(capsys):
    assert main(["list"]) == 0
    names = capsys.readouterr().out.split()
    assert "gn" in names and "oracle" in names


def _bad(argv, capsys, match):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and match in err[0], err


def test_log_without_scans(short_log, tmp_path, capsys):
    _bad(["run", "--algo", "gn", "--log", str(short_log / "empty.npz"), "--out", str(tmp_path)], capsys, "no scans")


def test_log_all_inf(short_log, tmp_path, capsys):
    _bad(["run", "--algo", "gn", "--log", str(short_log / "inf.npz"), "--out", str(tmp_path)], capsys, "inf")


def test_unknown_algorithm(short_log, tmp_path, capsys):
    _bad(["run", "--algo", "hector", "--log", str(short_log / "room.npz"), "--out", str(tmp_path)], capsys,
         "unknown algorithm 'hector'")


def test_config_with_unknown_key(short_log, tmp_path, capsys):
    cfg = tmp_path / "gn.yaml"
    cfg.write_text("map_resolution: 0.05\nupdate_factor_ocupied: 0.9\n")
    _bad(["run", "--algo", "gn", "--log", str(short_log / "room.npz"), "--out", str(tmp_path / "o"),
          "--config", str(cfg)], capsys, "did you mean 'update_factor_occupied'")


def test_missing_log_and_bad_nested_value(short_log, tmp_path, capsys):
    _bad(["run", "--algo", "gn", "--log", str(tmp_path / "nope.npz"), "--out", str(tmp_path)], capsys, "not found")
    cfg = tmp_path / "gn.yaml"
    cfg.write_text("preprocess: {smooth_beams: fast}\n")
    _bad(["run", "--algo", "gn", "--log", str(short_log / "room.npz"), "--out", str(tmp_path / "o"),
          "--config", str(cfg)], capsys, "preprocess.smooth_beams")


def test_negative_seed_is_refused_at_parse_time(short_log, tmp_path, capsys):
    _bad(["run", "--algo", "gn", "--log", str(short_log / "room.npz"), "--out", str(tmp_path / "o"),
          "--seed", "-1"], capsys, "error: --seed: must be an integer >= 0, got '-1'")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("where, problem", [("file", "--out must be a folder, this is a file"),
                                            ("under_file", "Not a directory"),
                                            ("read_only", "Permission denied")])
def test_out_that_cannot_be_written_fails_before_the_run(short_log, request, capsys, where, problem):
    out = {"file": lambda: request.getfixturevalue("a_file"),
           "under_file": lambda: request.getfixturevalue("a_file") / "o",
           "read_only": lambda: request.getfixturevalue("read_only_dir") / "o"}[where]()
    _bad(["run", "--algo", "gn", "--log", str(short_log / "room.npz"), "--out", str(out)], capsys,
         f"error: {out}: {problem}")


def test_ctrl_c_at_start_up(interrupted_main, capsys):
    import slam.__main__
    assert interrupted_main(slam.__main__, ["list"]) == 130
    assert capsys.readouterr().err == "interrupted\n"
