"""python -m bench add: a map made elsewhere (here: the oracle's, saved as map_server files)
joins a run's results and report beside the run's own algorithms; bad input is one line."""
import json
import shutil

import numpy as np
import pytest

from bench.__main__ import main
from bench.rundir import run_lock
from metrics import write_tum
from worlds import Grid, write_map
from tests.bench.conftest import TINY


@pytest.fixture(scope="module")
def base_run(tmp_path_factory):
    """A finished run of oracle and fake_map on the tiny world (made once, copied per test)."""
    out = tmp_path_factory.mktemp("add") / "run"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SLAM_BENCH_CACHE", str(tmp_path_factory.getbasetemp() / "logcache"))
        assert main(["run", "--world", TINY, "--algo", "oracle,fake_map", "--repeats", "1",
                     "--jobs", "1", "--out", str(out), "--no-progress", "--no-figures"]) == 0
    return out


@pytest.fixture
def run(base_run, tmp_path):
    return shutil.copytree(base_run, tmp_path / "run")


def _rows(run):
    return json.loads((run / "results.json").read_text())["rows"]


def _row(run, algo, repeat=0):
    return next(r for r in _rows(run) if r["algo"] == algo and r["repeat"] == repeat)


def _oracle_files(run, tmp_path, image_format="pgm", repeat=0):
    """The oracle's map of the run as a map_server pair, and its trajectory as TUM."""
    with np.load(run / "maps" / "tiny" / "oracle" / f"{repeat}.npz") as z:
        grid = Grid(z["prob"], float(z["resolution"]), z["origin"])
        write_tum(tmp_path / "oracle.tum", z["times"], z["poses"])
    yaml_path = tmp_path / f"oracle_{image_format}.yaml"
    write_map(grid, yaml_path, image_format=image_format)
    return yaml_path, tmp_path / "oracle.tum"


def _table_cells(md: str, title: str) -> dict[str, str]:
    """Column head -> the tiny row's cell of the table under the heading `title`."""
    lines = md[md.index(title):].splitlines()
    head = next(line for line in lines if line.startswith("| world |"))
    row = next(line for line in lines if line.startswith("| tiny |"))
    cells = [[c.strip() for c in line.strip().strip("|").split("|")] for line in (head, row)]
    return dict(zip(*cells))


def test_outside_map_scores_as_the_oracle(run, tmp_path, capsys):
    yaml_path, tum = _oracle_files(run, tmp_path)
    assert main(["add", str(run), "--world", "tiny", "--algo", "oracle_copy",
                 "--map", str(yaml_path), "--trajectory", str(tum)]) == 0
    out = capsys.readouterr().out
    assert f"report: {run / 'summary.md'}" in out and "tiny/oracle_copy/0: precision" in out

    oracle, mine = _row(run, "oracle"), _row(run, "oracle_copy")
    assert set(oracle) <= set(mine)
    assert mine["status"] == "ok" and mine["source"] == "outside"
    assert (mine["repeat"], mine["draw"], mine["slam_seed"]) == (0, 0, None)
    assert mine["log_seed"] == oracle["log_seed"]
    assert mine["map_source"] == str(yaml_path.resolve())
    for key in ("precision", "sensitivity", "precision_t1", "sensitivity_t1", "adnn_cells",
                "surface_precision", "surface_sensitivity", "surface_f1"):
        assert mine[key] == pytest.approx(oracle[key], abs=1e-12), key
    assert mine["rendered"] is False
    assert mine["ate_m"] == pytest.approx(0.0, abs=1e-6)
    assert (run / mine["map_file"]).is_file()

    md = (run / "summary.md").read_text()
    ps = _table_cells(md, "## Table 2:")     # the main table: the surface form
    assert ps["oracle_copy P"] == f"{oracle['surface_precision']:.3f} ± 0.000" == \
        ps["oracle (ceiling) P"]
    assert ps["oracle_copy S"] == f"{oracle['surface_sensitivity']:.3f} ± 0.000" == \
        ps["oracle (ceiling) S"]
    assert "fake_map (ceiling) P" in ps   # the fakes map with the true poses, as the oracle
    cell = _table_cells(md, "## Table 2, the study's cell rule")
    assert cell["oracle_copy P"] == f"{oracle['precision']:.3f} ± 0.000" == cell["oracle (ceiling) P"]
    assert _table_cells(md, "## Table 1:")["oracle_copy"] == f"{oracle['adnn_cells']:.2f} ± 0.00"
    assert "(`bench add`): oracle_copy." in md
    assert "tiny,oracle_copy,1,0," in (run / "summary.csv").read_text()
    assert (run / "figures" / "overlay_tiny_oracle_copy.png").is_file()

    # again, as a PNG map and without a trajectory: the next repeat, the same scores
    png, _ = _oracle_files(run, tmp_path, "png")
    assert main(["add", str(run), "--world", "tiny", "--algo", "oracle_copy", "--map", str(png),
                 "--no-figures"]) == 0
    second = _row(run, "oracle_copy", 1)
    assert second["precision"] == mine["precision"] and second["ate_m"] is None
    assert _table_cells((run / "summary.md").read_text(), "## Table 2:")["oracle_copy P"] == \
        f"{oracle['surface_precision']:.3f} ± 0.000"
    added = json.loads((run / "run.json").read_text())["added"]
    assert [(a["algo"], a["repeat"], a["rendered"]) for a in added] == [
        ("oracle_copy", 0, False), ("oracle_copy", 1, False)]

    # the outside rows are not tasks of the run: resuming it finds nothing to do
    assert main(["run", "--resume", str(run), "--jobs", "1", "--no-progress", "--no-figures"]) == 0
    assert "2/2 rows (0 failed)" in capsys.readouterr().err


def _err_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


@pytest.mark.parametrize("change, msg", [
    ({"dir": "EMPTY"}, "no run.json here: not a bench run directory"),
    ({"--world": "swirl_s"}, "--world swirl_s: not a world of this run (its worlds: tiny)"),
    ({"--map": "MISSING"}, "missing.yaml: file not found"),
    ({"--map": "BAD"}, "bad.yaml: resolution: missing required field"),
    ({"--map": "BROKEN_PNG"}, "broken.png: not an image"),
    ({"--algo": "oracle"}, "--algo oracle: an algorithm of this run (oracle, fake_map)"),
    ({"--algo": "fake_map"}, "--algo fake_map: an algorithm of this run"),
    ({"--algo": "pf"}, "--algo pf: the name of one of this project's algorithms"),
    ({"--algo": "../x"}, "--algo '../x': expected a name of letters"),
    ({"--draw": "1"}, "--draw 1: out of range (tiny has draws 0..0 in this run)"),
    ({"--draw": "-1"}, "--draw: must be an integer >= 0, got '-1'"),
    ({"--trajectory": "BAD_TUM"}, "bad.tum: line 1"),
    ({"--trajectory": "HUGE_TUM"}, "huge.tum: line 3: x: 1e+308 is beyond +-1e+06"),
    ({"--trajectory": "NAN_TUM"}, "nan.tum: line 3: non-finite y: nan"),
    ({"--trajectory": "FAR_TUM"}, "far.tum: line 3: x: 9 m is more than 2 m outside the world "
                                  "(-0.05..1.65 m)"),
    ({"--map": None}, "give --map MAP.yaml, or --trajectory T.tum with --render"),
])
def test_bad_input_is_one_line_exit_2(run, tmp_path, capsys, change, msg):
    yaml_path, _ = _oracle_files(run, tmp_path)
    (tmp_path / "bad.yaml").write_text("image: x.pgm\norigin: [0, 0, 0]\n")
    (tmp_path / "broken.png").write_text("not a picture\n")
    (tmp_path / "broken.yaml").write_text(yaml_path.read_text().replace("oracle_pgm.pgm", "broken.png"))
    (tmp_path / "bad.tum").write_text("0 1 2\n")
    two = "0 0.5 0.5 0 0 0 0 1\n0.1 0.6 0.5 0 0 0 0 1\n"
    (tmp_path / "huge.tum").write_text(two + "0.2 1e308 0.5 0 0 0 0 1\n")
    (tmp_path / "nan.tum").write_text(two + "0.2 0.7 nan 0 0 0 0 1\n")
    (tmp_path / "far.tum").write_text(two + "0.2 9 0.5 0 0 0 0 1\n")   # world: x -0.05..1.65
    (tmp_path / "empty").mkdir()
    files = {"EMPTY": tmp_path / "empty", "MISSING": tmp_path / "missing.yaml",
             "BAD": tmp_path / "bad.yaml", "BROKEN_PNG": tmp_path / "broken.yaml",
             "BAD_TUM": tmp_path / "bad.tum", "HUGE_TUM": tmp_path / "huge.tum",
             "NAN_TUM": tmp_path / "nan.tum", "FAR_TUM": tmp_path / "far.tum"}
    args = {"dir": run, "--world": "tiny", "--algo": "outside", "--map": yaml_path}
    args.update(change)
    argv = ["add", str(files.get(args.pop("dir"), run))]
    for k, v in args.items():
        if v is not None:
            argv += [k, str(files.get(v, v))]
    before = (run / "results.json").read_bytes()
    assert main(argv) == 2
    assert msg in _err_line(capsys)
    assert (run / "results.json").read_bytes() == before


@pytest.mark.parametrize("prob", [0.5, 0.0], ids=["all-unknown", "all-free"])
def test_a_map_without_an_occupied_cell_is_a_failed_row_as_metrics_score_says(run, tmp_path,
                                                                              capsys, prob):
    """metrics score refuses a map without an occupied cell; bench add stored it as ok with
    P = S = 0. Now: a failed row whose error is metrics score's own line."""
    from metrics.__main__ import main as metrics_main
    empty = tmp_path / "empty_map.yaml"
    write_map(Grid(np.full((30, 30), prob), 0.05, np.zeros(3)), empty)
    assert metrics_main(["score", "--map", str(empty), "--truth", TINY]) == 2
    refusal = _err_line(capsys).removeprefix("error: ")
    assert main(["add", str(run), "--world", "tiny", "--algo", "blank", "--map", str(empty),
                 "--no-figures"]) == 0
    row = _row(run, "blank")
    assert row["status"] == "failed" and row["error"] == refusal
    assert row.get("precision") is None and row.get("surface_precision") is None
    assert "blank" in (run / "summary.md").read_text()


def test_a_relative_run_folder(run, tmp_path, capsys, monkeypatch):
    """The row and run.json land in the run folder, not in a copy of its path inside it."""
    yaml_path, _ = _oracle_files(run, tmp_path)
    monkeypatch.chdir(tmp_path)
    assert main(["add", "run", "--world", "tiny", "--algo", "rel", "--map", str(yaml_path),
                 "--no-figures"]) == 0
    assert _row(run, "rel")["status"] == "ok" and not (run / "run").exists()
    assert json.loads((run / "run.json").read_text())["added"][-1]["algo"] == "rel"


def test_a_run_in_progress_is_refused(run, tmp_path, capsys):
    yaml_path, _ = _oracle_files(run, tmp_path)
    with run_lock(run):
        assert main(["add", str(run), "--world", "tiny", "--algo", "x", "--map", str(yaml_path),
                     "--no-figures"]) == 2
    assert "in use by another bench run" in _err_line(capsys)
    assert main(["add", str(run), "--world", "tiny", "--algo", "x", "--map", str(yaml_path),
                 "--no-figures"]) == 0


def test_draw_takes_the_draws_log_seed(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--world", TINY, "--algo", "oracle", "--repeats", "1", "--draws", "2",
                 "--seed", "5", "--jobs", "1", "--out", str(out), "--no-progress",
                 "--no-figures"]) == 0
    yaml_path, tum = _oracle_files(out, tmp_path, repeat=1)   # draw 1's oracle run
    assert main(["add", str(out), "--world", "tiny", "--algo", "ros", "--map", str(yaml_path),
                 "--draw", "1", "--trajectory", str(tum), "--no-figures"]) == 0
    row, oracle = _row(out, "ros"), _row(out, "oracle", 1)
    assert (row["draw"], row["log_seed"]) == (1, oracle["log_seed"]) == (1, 6)
    assert row["precision"] == pytest.approx(oracle["precision"], abs=1e-12)
    assert row["ate_m"] == pytest.approx(0.0, abs=1e-6)
    md = (out / "summary.md").read_text()
    assert "## Across noise draws" in md and "| ros P | ros S | oracle (ceiling) P |" in md


def test_trajectory_without_a_true_path_is_refused(run, tmp_path, capsys):
    yaml_path, tum = _oracle_files(run, tmp_path)
    (run / "maps" / "tiny" / "gt_s0.npz").unlink()   # as for a real robot's log
    assert main(["add", str(run), "--world", "tiny", "--algo", "x", "--map", str(yaml_path),
                 "--trajectory", str(tum)]) == 2
    assert "gt_s0.npz: missing: the run's true path of tiny log seed 0 is needed" in _err_line(capsys)
    assert main(["add", str(run), "--world", "tiny", "--algo", "x", "--map", str(yaml_path),
                 "--no-figures"]) == 0


def _npz(path):
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def test_render_the_oracles_trajectory_gives_the_oracles_map(run, tmp_path, capsys):
    """The oracle's own poses, given as an outside trajectory and rendered with the output
    map from the run's log, give the oracle's map and scores: an outside SLAM's poses are
    compared map for map through the same map building."""
    _, tum = _oracle_files(run, tmp_path)
    assert main(["add", str(run), "--world", "tiny", "--algo", "mine", "--trajectory", str(tum),
                 "--render", "--no-figures"]) == 0
    assert "tiny/mine/0: precision" in capsys.readouterr().out
    oracle, mine = _row(run, "oracle"), _row(run, "mine")
    assert mine["rendered"] is True and mine["source"] == "outside" and mine["map_source"] is None
    assert mine["trajectory_source"] == str(tum.resolve())
    ours, theirs = _npz(run / mine["map_file"]), _npz(run / oracle["map_file"])
    assert mine["map_file"] == "maps/tiny/mine/0.npz"
    for key in ("prob", "resolution", "origin"):
        np.testing.assert_array_equal(ours[key], theirs[key], err_msg=key)
    for key in ("surface_precision", "surface_sensitivity", "precision", "sensitivity",
                "adnn_cells"):
        assert mine[key] == oracle[key], key
    assert mine["ate_m"] == pytest.approx(0.0, abs=1e-6)
    assert json.loads((run / "run.json").read_text())["added"][-1]["rendered"] is True

    # only the second half of the trajectory: the scans before it are left out
    times, poses = ours["times"], ours["poses"]
    half = len(times) // 2
    write_tum(tmp_path / "half.tum", times[half:], poses[half:])
    assert main(["add", str(run), "--world", "tiny", "--algo", "mine", "--trajectory",
                 str(tmp_path / "half.tum"), "--render", "--no-figures"]) == 0
    part = _npz(run / _row(run, "mine", 1)["map_file"])
    assert np.isfinite(part["prob"]).sum() < np.isfinite(ours["prob"]).sum()


def test_render_over_a_run_of_given_logs(tmp_path, tiny, capsys, monkeypatch):
    """A run over --logs: the log to render is the given file."""
    import glob
    from bench.cache import cache_dir
    logs = tmp_path / "logs"
    logs.mkdir()
    out = tmp_path / "run"
    assert main(["run", "--world", tiny, "--algo", "oracle", "--repeats", "1", "--jobs", "1",
                 "--out", str(tmp_path / "rec"), "--no-progress", "--no-figures"]) == 0
    src = sorted(glob.glob(str(cache_dir() / "tiny-s0-*.npz")))[0]
    shutil.copy(src, logs / "tiny.npz")
    shutil.copy(tiny, logs)   # a log's world is read from the log's folder
    assert main(["run", "--logs", str(logs), "--algo", "oracle", "--repeats", "1", "--jobs", "1",
                 "--out", str(out), "--no-progress", "--no-figures"]) == 0
    _, tum = _oracle_files(out, tmp_path)
    monkeypatch.setenv("SLAM_BENCH_CACHE", str(tmp_path / "empty_cache"))  # not the cache's
    assert main(["add", str(out), "--world", "tiny", "--algo", "mine", "--trajectory", str(tum),
                 "--render", "--no-figures"]) == 0
    mine, oracle = _row(out, "mine"), _row(out, "oracle")
    np.testing.assert_array_equal(_npz(out / mine["map_file"])["prob"],
                                  _npz(out / oracle["map_file"])["prob"])


def test_render_errors_are_one_line(run, tmp_path, capsys, monkeypatch):
    yaml_path, tum = _oracle_files(run, tmp_path)
    times = _npz(run / "maps" / "tiny" / "oracle" / "0.npz")["times"]
    late = tmp_path / "late.tum"
    late.write_text("".join(f"{1000.0 + t:.6f} 0.5 0.5 0 0 0 0 1\n" for t in times[:3]))
    base = ["add", str(run), "--world", "tiny", "--algo", "mine", "--no-figures"]
    before = (run / "results.json").read_bytes()
    for extra, msg in [
            (["--render", "--map", str(yaml_path), "--trajectory", str(tum)],
             "--render builds the map from --trajectory: give --map or --render, not both"),
            (["--render"], "--render needs --trajectory T.tum"),
            (["--render", "--trajectory", str(late)],
             f"{late}: t: the trajectory's times 1000.000..")]:
        assert main(base + extra) == 2, extra
        assert msg in _err_line(capsys), extra
    monkeypatch.setenv("SLAM_BENCH_CACHE", str(tmp_path / "empty_cache"))
    assert main(base + ["--render", "--trajectory", str(tum)]) == 2
    line = _err_line(capsys)
    assert str(tmp_path / "empty_cache") in line
    assert "missing: the sensor log of tiny log seed 0 (noise realistic) is needed to render" in line
    assert (run / "results.json").read_bytes() == before


def test_a_run_stored_before_the_surfaces_scores_the_cell_form(run, tmp_path, capsys):
    """truth.npz without `surfaces` (a run folder written before them) still loads: the added
    row has the cell form only, and the world's tables fall back to the cell form."""
    p = run / "maps" / "tiny" / "truth.npz"
    z = _npz(p)
    assert z.pop("surfaces").shape[1] == 4
    np.savez_compressed(p, **z)
    yaml_path, _ = _oracle_files(run, tmp_path)
    assert main(["add", str(run), "--world", "tiny", "--algo", "old", "--map", str(yaml_path)]) == 0
    assert "(study's cell rule)" in capsys.readouterr().out
    old, oracle = _row(run, "old"), _row(run, "oracle")
    assert "surface_precision" not in old and old["precision"] == oracle["precision"]
    md = (run / "summary.md").read_text()
    ps = _table_cells(md, "## Table 2:")
    assert ps["old P"] == f"{oracle['precision']:.3f} ± 0.000 (cell)" == ps["oracle (ceiling) P"]
    assert "Worlds without the surfaces (tiny" in md
