import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from sim.__main__ import main
from sim.logs import read_log

ROOM = """name: cli_room
walls:
  thickness: 0.1
  polylines:
    - [[0, 0], [3, 0], [3, 3], [0, 3], [0, 0]]
robot:
  start: [0.6, 0.6, 0.0]
route:
  - [2.2, 0.6]
  - [2.2, 2.0]
"""


@pytest.fixture
def room_yaml(tmp_path):
    p = tmp_path / "room.yaml"
    p.write_text(ROOM)
    return p


def _error_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")
    return err[0]


def test_record_and_show(tmp_path, room_yaml, capsys):
    pytest.importorskip("worlds.load")
    out = tmp_path / "log.npz"
    assert main(["record", "--world", str(room_yaml), "--seed", "2", "--out", str(out),
                 "--noise", "gazebo"]) == 0
    log = read_log(out)
    assert log.meta["world"] == "cli_room" and log.meta["noise"]["name"] == "gazebo"
    assert log.n_scans > 10 and log.has_odometry and log.has_imu and log.has_ground_truth
    assert main(["show", str(out), "--out", str(tmp_path / "paths.png")]) == 0
    assert (tmp_path / "paths.png").stat().st_size > 1000
    assert main(["show", str(out)]) == 0                     # default: beside the log
    assert out.with_suffix(".png").exists()


def test_record_with_config_file(tmp_path, room_yaml):
    pytest.importorskip("worlds.load")
    cfg = tmp_path / "rec.yaml"
    cfg.write_text("lidar: {beams: 90}\n")
    out = tmp_path / "log.npz"
    assert main(["record", "--world", str(room_yaml), "--out", str(out), "--config", str(cfg),
                 "--noise", "ideal"]) == 0
    assert read_log(out).scan_ranges.shape[1] == 90


def test_unknown_profile_name(tmp_path, room_yaml, capsys):
    assert main(["record", "--world", str(room_yaml), "--out", str(tmp_path / "x.npz"),
                 "--noise", "noisy"]) == 2
    assert "unknown noise profile 'noisy'" in _error_line(capsys)
    assert not (tmp_path / "x.npz").exists()


def test_profile_with_a_wrong_key(tmp_path, room_yaml, capsys):
    prof = tmp_path / "prof.yaml"
    prof.write_text("imu: {gyro: {densty: 1.0e-4}}\n")
    assert main(["record", "--world", str(room_yaml), "--out", str(tmp_path / "x.npz"),
                 "--noise", str(prof)]) == 2
    line = _error_line(capsys)
    assert "prof.yaml" in line and "imu.gyro.densty: unknown key" in line and "density" in line


def test_unknown_world(tmp_path, capsys):
    assert main(["record", "--world", "atlantis", "--out", str(tmp_path / "x.npz")]) == 2
    assert "atlantis" in _error_line(capsys)


def _good_log(tmp_path, room_yaml):
    out = tmp_path / "good.npz"
    assert main(["record", "--world", str(room_yaml), "--out", str(out), "--noise", "ideal"]) == 0
    return out


def test_unreadable_truncated_and_newer_logs(tmp_path, room_yaml, capsys):
    pytest.importorskip("worlds.load")
    good = _good_log(tmp_path, room_yaml)
    capsys.readouterr()
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not a zip file at all")
    assert main(["show", str(garbage)]) == 2
    assert "garbage.npz" in _error_line(capsys)

    data = good.read_bytes()
    trunc = tmp_path / "trunc.npz"
    trunc.write_bytes(data[: len(data) // 2])
    assert main(["show", str(trunc)]) == 2
    assert "trunc.npz" in _error_line(capsys)

    assert main(["show", str(tmp_path / "missing.npz")]) == 2
    assert "file not found" in _error_line(capsys)

    # a log written by a newer version of the format
    newer = tmp_path / "newer.npz"
    with zipfile.ZipFile(good) as zin, zipfile.ZipFile(newer, "w") as zout:
        for item in zin.infolist():
            raw = zin.read(item)
            if item.filename == "meta.npy":
                import io
                meta = json.loads(str(np.load(io.BytesIO(raw)).reshape(-1)[0]))
                meta["format_version"] = 99
                buf = io.BytesIO()
                np.save(buf, np.array([json.dumps(meta)]))
                raw = buf.getvalue()
            zout.writestr(item, raw)
    assert main(["show", str(newer)]) == 2
    line = _error_line(capsys)
    assert "format_version" in line and "99" in line and "newer" in line


def test_import_of_a_missing_file(tmp_path, capsys):
    pytest.importorskip("sim.logs.carmen")
    assert main(["import", str(tmp_path / "nothing.log"), "--out", str(tmp_path / "x.npz")]) == 2
    assert "nothing.log" in _error_line(capsys)


def test_show_without_a_loadable_world(tmp_path):
    from sim import record, write_log
    from tests.sim.worlds_fixtures import square_room
    log = record(square_room(route=[[3.0, 2.0]]), seed=0, noise="ideal")   # world "square": no file
    write_log(log, tmp_path / "square.npz")
    assert main(["show", str(tmp_path / "square.npz"), "--out", str(tmp_path / "s.png")]) == 0
    assert (tmp_path / "s.png").stat().st_size > 1000


STUCK_WORLD = Path(__file__).resolve().parents[1] / "data" / "stuck_world.yaml"


def _warning_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("warning: ")
    return err[0]


def test_record_of_a_route_the_robot_cannot_finish_warns_and_exits_3(tmp_path, capsys):
    world = STUCK_WORLD
    cfg = tmp_path / "rec.yaml"
    cfg.write_text("controller: {stuck_timeout: 4.0}\n")
    out = tmp_path / "log.npz"
    assert main(["record", "--world", str(world), "--out", str(out), "--config", str(cfg)]) == 3
    line = _warning_line(capsys)
    assert str(out) in line and "log ended stuck after" in line and "of 2.0 m" in line
    log = read_log(out)                                     # written all the same
    assert log.meta["ending"] == "stuck" and 0.0 < log.meta["route_driven"] < 1.0


def test_record_cut_short_by_max_duration_warns_and_exits_3(tmp_path, room_yaml, capsys):
    cfg = tmp_path / "rec.yaml"
    cfg.write_text("max_duration: 4.0\n")
    out = tmp_path / "log.npz"
    assert main(["record", "--world", str(room_yaml), "--out", str(out), "--config", str(cfg)]) == 3
    assert "log hit the time limit after" in _warning_line(capsys)
    log = read_log(out)
    assert log.meta["ending"] == "time limit" and log.gt_t[-1] == pytest.approx(4.0, abs=0.03)


def test_record_that_sees_too_little_of_the_walls_warns(tmp_path, capsys):
    big = ROOM.replace("[[0, 0], [3, 0], [3, 3], [0, 3], [0, 0]]",
                       "[[0, 0], [12, 0], [12, 12], [0, 12], [0, 0]]")
    (tmp_path / "big.yaml").write_text(big)
    out = tmp_path / "log.npz"
    assert main(["record", "--world", str(tmp_path / "big.yaml"), "--out", str(out)]) == 3
    assert "of the wall cells (< 95 %)" in _warning_line(capsys)
    cover = read_log(out).meta["wall_coverage"]
    assert 0.0 < cover < 0.95
    assert main(["record", "--world", str(tmp_path / "big.yaml"), "--out", str(out),
                 "--min-coverage", f"{cover - 0.01:.3f}"]) == 0
    assert main(["record", "--world", str(tmp_path / "big.yaml"), "--out", str(out),
                 "--min-coverage", "2"]) == 2
    assert "--min-coverage" in _error_line(capsys)


def test_negative_seed_is_refused_at_parse_time(tmp_path, room_yaml, capsys):
    out = tmp_path / "x.npz"
    assert main(["record", "--world", str(room_yaml), "--seed", "-1", "--out", str(out)]) == 2
    assert _error_line(capsys) == "error: --seed: must be an integer >= 0, got '-1'"
    assert not out.exists()


@pytest.mark.parametrize("where, problem", [("under_file", "Not a directory"),
                                            ("folder", "--out must be a file, this is a folder"),
                                            ("read_only", "Permission denied")])
def test_out_that_cannot_be_written_fails_before_recording(tmp_path, room_yaml, request, capsys,
                                                           where, problem):
    out = {"under_file": lambda: request.getfixturevalue("a_file") / "log.npz",
           "folder": lambda: tmp_path,
           "read_only": lambda: request.getfixturevalue("read_only_dir") / "log.npz"}[where]()
    assert main(["record", "--world", str(room_yaml), "--out", str(out)]) == 2
    line = _error_line(capsys)
    assert line.startswith(f"error: {out}: ") and problem in line


def test_ctrl_c_at_start_up(interrupted_main, capsys):
    import sim.__main__
    assert interrupted_main(sim.__main__, ["record", "--world", "x", "--out", "x.npz"]) == 130
    assert capsys.readouterr().err == "interrupted\n"
