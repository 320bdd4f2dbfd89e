"""python -m metrics: score / trajectory / relations on small files; bad input gives one line, exit 2."""
import json

import numpy as np
import pytest

from metrics.__main__ import main
from sim.logs.tum import write_tum
from tests.metrics.maps import ROOM, draw
from worlds.grid import Grid
from worlds.mapio import write_map

CONTRACT = {"precision", "sensitivity", "f1", "tp", "fp", "fn", "adnn_cells", "adnn_m", "align",
            "adnn_reverse_cells", "adnn_reverse_m", "chamfer_cells", "align_mode"}


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    d = tmp_path_factory.mktemp("maps")
    write_map(draw(ROOM), d / "truth.yaml")
    write_map(draw(ROOM, pose=(0.05, -0.05, 0.03)), d / "est.yaml")
    return d


def run(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(code, out, err):
    assert code == 2
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err


def test_score_json_contract(maps, capsys, tmp_path):
    pic = tmp_path / "o.png"
    code, out, err = run(capsys, ["score", "--map", maps / "est.yaml", "--truth", maps / "truth.yaml",
                                  "--json", "--picture", pic, "--tolerance", "1"])
    assert code == 0, err
    r = json.loads(out)
    assert CONTRACT <= set(r) and set(r["align"]) == {"x", "y", "yaw"}
    assert r["precision"] == 1.0 and r["sensitivity"] == 1.0 and r["tolerance"] == 1
    assert r["align_mode"] == "icp"
    assert abs(r["align"]["yaw"] - 0.03) < np.deg2rad(0.5)
    assert pic.read_bytes()[:4] == b"\x89PNG"


def test_score_identical_text_output_and_global(maps, capsys):
    code, out, _ = run(capsys, ["score", "--map", maps / "truth.yaml", "--truth", maps / "truth.yaml",
                                "--start", "none"])
    assert code == 0
    assert "precision" in out and "align_mode               global" in out


def test_missing_pgm(maps, capsys, tmp_path):
    write_map(draw(ROOM), tmp_path / "m.yaml")
    (tmp_path / "m.pgm").unlink()
    one_line_error(*run(capsys, ["score", "--map", tmp_path / "m.yaml", "--truth", maps / "truth.yaml"]))


def test_pgm_size_disagrees(maps, capsys, tmp_path):
    write_map(draw(ROOM), tmp_path / "m.yaml")
    data = (tmp_path / "m.pgm").read_bytes()
    (tmp_path / "m.pgm").write_bytes(data[: len(data) // 2])  # header promises more pixels
    code, out, err = run(capsys, ["score", "--map", tmp_path / "m.yaml", "--truth", maps / "truth.yaml"])
    one_line_error(code, out, err)
    assert "truncated" in err


@pytest.mark.parametrize("content", [b"\x89PNG\r\n\x1a\n\x00\x00binary", b"just: [a, mapping]\n",
                                     b"- a list\n"])
def test_non_map_files(maps, capsys, tmp_path, content):
    f = tmp_path / "x.yaml"
    f.write_bytes(content)
    one_line_error(*run(capsys, ["score", "--map", f, "--truth", maps / "truth.yaml"]))


def test_pgm_given_instead_of_yaml(maps, capsys):
    one_line_error(*run(capsys, ["score", "--map", maps / "est.pgm", "--truth", maps / "truth.yaml"]))


def test_empty_maps(maps, capsys, tmp_path):
    write_map(Grid(np.zeros((20, 20))), tmp_path / "empty.yaml")
    code, out, err = run(capsys, ["score", "--map", tmp_path / "empty.yaml", "--truth", maps / "truth.yaml"])
    one_line_error(code, out, err)
    assert "no occupied cell" in err
    code, out, err = run(capsys, ["score", "--map", maps / "est.yaml", "--truth", tmp_path / "empty.yaml"])
    one_line_error(code, out, err)
    assert "no occupied cell" in err


@pytest.mark.parametrize("flag, value, msg", [
    ("--start", "1,2", "--start: expected X,Y,YAW (3 numbers)"),
    ("--start", "nan,0,0", "--start: expected X,Y,YAW (finite numbers)"),
    ("--start", "0,inf,0", "--start: expected X,Y,YAW (finite numbers)"),
    ("--start", "0,0,yaw", "--start: expected X,Y,YAW (numbers)"),
    ("--tolerance", "-1", "--tolerance: must be an integer in 0..50, got '-1'"),
    ("--tolerance", "1000", "--tolerance: must be an integer in 0..50, got '1000'"),
    ("--tolerance", "1.5", "--tolerance: expected an integer, got '1.5'"),
    ("--tau", "nan", "--tau: expected a finite number"),
    ("--tau", "-0.01", "--tau: must be in [0, 1]"),
    ("--occupied-thresh", "1.5", "--occupied-thresh: must be in [0, 1]"),
    ("--picture", "x.txt", "--picture: expected a .png, .pdf or .svg file, got 'x.txt'"),
    ("--picture", "overlay", "--picture: expected a .png, .pdf or .svg file"),
])
def test_bad_score_flags_fail_at_parse_time(maps, capsys, flag, value, msg):
    code, out, err = run(capsys, ["score", "--map", maps / "est.yaml", "--truth", maps / "truth.yaml",
                                  flag, value])
    one_line_error(code, out, err)
    assert err.startswith(f"error: {msg}")


@pytest.mark.parametrize("where, problem", [("under_file", "Not a directory"),
                                            ("read_only", "Permission denied")])
def test_picture_that_cannot_be_written(maps, capsys, request, where, problem):
    folder = request.getfixturevalue("a_file" if where == "under_file" else "read_only_dir")
    pic = folder / "o.png"
    code, out, err = run(capsys, ["score", "--map", maps / "est.yaml", "--truth", maps / "truth.yaml",
                                  "--picture", pic])
    one_line_error(code, out, err)
    assert err.startswith(f"error: {pic}: {problem}")


def test_picture_as_svg(maps, capsys, tmp_path):
    code, out, err = run(capsys, ["score", "--map", maps / "est.yaml", "--truth", maps / "truth.yaml",
                                  "--picture", tmp_path / "o.svg"])
    assert code == 0, err
    assert b"<svg" in (tmp_path / "o.svg").read_bytes()[:500]


def test_map_with_a_nan_origin(maps, capsys, tmp_path):
    write_map(draw(ROOM), tmp_path / "m.yaml")
    text = (tmp_path / "m.yaml").read_text()
    (tmp_path / "m.yaml").write_text(text.replace("origin: [-0.525,", "origin: [.nan,"))
    code, out, err = run(capsys, ["score", "--map", tmp_path / "m.yaml", "--truth", maps / "truth.yaml"])
    one_line_error(code, out, err)
    assert err.startswith(f"error: {tmp_path / 'm.yaml'}: origin: expected finite numbers")


def test_ctrl_c_at_start_up(interrupted_main, capsys):
    import metrics.__main__
    assert interrupted_main(metrics.__main__, ["score"]) == 130
    assert capsys.readouterr().err == "interrupted\n"


def test_trajectory_command(capsys, tmp_path):
    t = np.linspace(0, 20, 201)
    gt = np.column_stack([0.1 * t, np.sin(0.2 * t), 0.1 * t])
    write_tum(tmp_path / "gt.tum", t, gt)
    write_tum(tmp_path / "est.tum", t, gt + [0.3, 0.4, 0.0])
    code, out, err = run(capsys, ["trajectory", "--est", tmp_path / "est.tum", "--truth",
                                  tmp_path / "gt.tum", "--json"])
    assert code == 0, err
    r = json.loads(out)
    assert r["ate_start_m"] == pytest.approx(0.5, abs=1e-6)
    assert r["ate_m"] == pytest.approx(0.0, abs=1e-6)
    assert r["rpe_trans_m"] == pytest.approx(0.0, abs=1e-6)
    (tmp_path / "bad.tum").write_text("0 1 2\n")
    one_line_error(*run(capsys, ["trajectory", "--est", tmp_path / "bad.tum", "--truth",
                                 tmp_path / "gt.tum"]))


def test_trajectory_truth_from_a_sensor_log(capsys, tmp_path):
    from sim.logs import SensorLog, write_log
    t = np.linspace(0, 20, 201)
    gt = np.column_stack([0.1 * t, np.sin(0.2 * t), 0.1 * t])
    write_log(SensorLog(t[:3], np.ones((3, 4)), np.linspace(0, 3, 4), gt_t=t, gt_pose=gt), tmp_path / "log.npz")
    write_tum(tmp_path / "est.tum", t, gt + [0.3, 0.4, 0.0])
    code, out, err = run(capsys, ["trajectory", "--est", tmp_path / "est.tum", "--truth",
                                  tmp_path / "log.npz", "--json"])
    assert code == 0, err
    assert json.loads(out)["ate_start_m"] == pytest.approx(0.5, abs=1e-6)
    write_log(SensorLog(t[:3], np.ones((3, 4)), np.linspace(0, 3, 4)), tmp_path / "nogt.npz")
    one_line_error(*run(capsys, ["trajectory", "--est", tmp_path / "est.tum", "--truth",
                                   tmp_path / "nogt.npz"]))


def test_relations_command_is_wired(capsys, tmp_path):
    pytest.importorskip("metrics.relations")
    t = np.arange(0.0, 10.0, 0.5)
    poses = np.column_stack([t, 0 * t, 0 * t])
    write_tum(tmp_path / "est.tum", t, poses)
    (tmp_path / "rel.txt").write_text("1.0 2.0 1.0 0 0 0 0 0\n3.0 5.0 2.0 0 0 0 0 0\n")
    code, out, err = run(capsys, ["relations", "--traj", tmp_path / "est.tum", "--relations",
                                  tmp_path / "rel.txt", "--json"])
    assert code == 0, err
    r = json.loads(out)
    assert r["n_used"] == 2 and r["abs_trans_mean"] == pytest.approx(0.0, abs=1e-9)
    one_line_error(*run(capsys, ["relations", "--traj", tmp_path / "none.tum", "--relations",
                                 tmp_path / "rel.txt"]))


WORLD = """name: room
walls:
  thickness: 0.1
  polylines:
    - [[0, 0], [3.013, 0], [3.013, 2.05], [0, 2.05], [0, 0]]
obstacles:
  - {box: {center: [2.0, 1.0], size: [0.4, 0.3], yaw: 0.5}}
robot:
  start: [0.6, 0.6, 0.0]
"""


def test_score_against_a_world_gives_both_forms(capsys, tmp_path):
    from worlds.load import load_world
    from worlds.raster import rasterize
    (tmp_path / "room.yaml").write_text(WORLD)
    write_map(rasterize(load_world(str(tmp_path / "room.yaml"))), tmp_path / "est.yaml")
    pic = tmp_path / "s.png"
    code, out, err = run(capsys, ["score", "--map", tmp_path / "est.yaml", "--truth",
                                  tmp_path / "room.yaml", "--json", "--tau", "0.01",
                                  "--picture", pic])
    assert code == 0, err
    r = json.loads(out)
    assert CONTRACT <= set(r)
    assert r["surface_precision"] == 1.0 and r["surface_sensitivity"] == pytest.approx(1.0, abs=1e-3)
    assert r["surface_tau_m"] == 0.01 and r["precision"] == 1.0
    assert r["forms"]["precision"].startswith("cell: the study's exact rule")
    assert r["forms"]["surface_precision"] == "surface: wall surfaces of room, tau 0.01 m"
    assert pic.read_bytes()[:4] == b"\x89PNG"


def test_tau_needs_a_world(maps, capsys):
    code, out, err = run(capsys, ["score", "--map", maps / "est.yaml", "--truth", maps / "truth.yaml",
                                  "--tau", "0.01"])
    one_line_error(code, out, err)
    assert "needs the world's YAML" in err


def test_trajectory_with_a_huge_value_is_one_line(capsys, tmp_path):
    """A TUM line holding 1e308 gave exit 0 and an alignment of -3e307: now exit 2, naming
    the file, the line and the field."""
    t = np.linspace(0, 20, 201)
    gt = np.column_stack([0.1 * t, np.sin(0.2 * t), 0.1 * t])
    write_tum(tmp_path / "gt.tum", t, gt)
    lines = (tmp_path / "gt.tum").read_text().splitlines()
    lines[3] = lines[3].replace(lines[3].split()[1], "1e308", 1)
    (tmp_path / "huge.tum").write_text("\n".join(lines) + "\n")
    code, out, err = run(capsys, ["trajectory", "--est", tmp_path / "huge.tum", "--truth",
                                  tmp_path / "gt.tum"])
    one_line_error(code, out, err)
    assert f"{tmp_path / 'huge.tum'}: line 4: x: 1e+308 is beyond" in err and out == ""
