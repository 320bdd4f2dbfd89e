"""python -m bench: one-line errors with exit 2, run prints the report path, report rebuilds."""
import pytest

from bench.__main__ import main


def _err_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")
    return err[0]


@pytest.mark.parametrize("args, msg", [
    (["--world", "no_such_world"], "no such world"),
    (["--algo", "nope"], "unknown algorithm 'nope'"),
    (["--repeats", "0"], "--repeats: must be an integer >= 1, got '0'"),
    (["--seed", "-1"], "--seed: must be an integer >= 0, got '-1'"),
    (["--jobs", "0"], "--jobs: must be an integer >= 1"),
    (["--draws", "-1"], "--draws: must be an integer >= 1"),
    (["--min-coverage", "nan"], "--min-coverage: expected a finite number"),
    (["--algo", ""], "--algo is empty"),
    (["--config", "fake_map"], "ALGO=YAML"),
    (["--noise", "nope"], "unknown noise profile 'nope'"),
    (["--world", "BAD"], "bad.yaml: walls: missing required field"),
])
def test_bad_input_is_one_line_exit_2(tiny, tmp_path, capsys, args, msg):
    base = {"--world": tiny, "--algo": "fake_map", "--repeats": "1"}
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nrobot: {start: [0, 0, 0]}\n")
    for k, v in zip(args[::2], args[1::2]):
        base[k] = str(bad) if v == "BAD" else v
    argv = ["run", *sum(([k, v] for k, v in base.items()), []), "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    assert msg in _err_line(capsys)


def test_run_report_and_refusal_to_overwrite(tiny, tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["run", "--world", tiny, "--algo", "fake_map,fake_raise", "--repeats", "2",
            "--jobs", "1", "--out", str(out), "--no-progress"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert f"report: {out / 'summary.md'}" in captured.out
    md = (out / "summary.md").read_text()
    # the fakes map with the true poses (uses_ground_truth): ceilings, as the oracle
    assert "| world | fake_map (ceiling) | fake_raise (ceiling) |" in md and "| tiny | " in md
    # the main table is the surface form, the study's cell rule beside it; both in the CSV
    from bench import read_rows
    from metrics.surface import DEFAULT_TAU_M
    ok = [r for r in read_rows(out) if r["status"] == "ok"]
    lines = md.splitlines()
    main_t = lines.index("## Table 2: precision (P) and sensitivity (S) of the walls, surface "
                         "form, mean ± std")
    assert lines[main_t + 2].startswith(f"Main form: surface, tau = {DEFAULT_TAU_M:g} m")
    mean = sum(r["surface_precision"] for r in ok) / len(ok)
    assert lines[main_t + 6].startswith(f"| tiny | {mean:.3f} ± ")
    cell_t = next(i for i, line in enumerate(lines) if line.startswith("## Table 2, the study's"))
    mean = sum(r["precision"] for r in ok) / len(ok)
    assert lines[cell_t + 4].startswith(f"| tiny | {mean:.3f} ± ")
    csv_head = (out / "summary.csv").read_text().splitlines()[0].split(",")
    assert {"surface_precision_mean", "surface_sensitivity_std", "surface_f1_mean",
            "precision_mean", "sensitivity_mean"} <= set(csv_head)
    assert (out / "figures" / "overlay_tiny_fake_map.png").exists()
    assert (out / "figures" / "trajectories_tiny.png").exists()
    assert (out / "figures" / "precision_sensitivity.png").exists()
    # a second run into the same folder is refused
    assert main(argv) == 2
    assert "already holds another run's results" in _err_line(capsys)
    # the report is rebuilt from results.json alone
    (out / "summary.md").unlink()
    assert main(["report", str(out)]) == 0
    assert (out / "summary.md").read_text() == md
    assert main(["report", str(tmp_path / "nothing")]) == 2
    assert "file not found" in _err_line(capsys)


def test_resume_with_other_arguments_is_refused(tiny, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--world", tiny, "--algo", "fake_map", "--repeats", "1", "--jobs", "1",
                 "--out", str(out), "--no-progress", "--no-figures"]) == 0
    capsys.readouterr()
    assert main(["run", "--resume", str(out), "--repeats", "2"]) == 2
    assert "other arguments" in _err_line(capsys)
    assert main(["run", "--resume", str(out), "--jobs", "1", "--no-figures"]) == 0


@pytest.mark.parametrize("where, problem", [("file", "--out must be a folder, this is a file"),
                                            ("under_file", "Not a directory"),
                                            ("read_only", "Permission denied")])
def test_out_that_cannot_be_written_fails_before_the_run(tiny, request, capsys, where, problem):
    out = {"file": lambda: request.getfixturevalue("a_file"),
           "under_file": lambda: request.getfixturevalue("a_file") / "run",
           "read_only": lambda: request.getfixturevalue("read_only_dir") / "run"}[where]()
    assert main(["run", "--world", tiny, "--algo", "fake_map", "--repeats", "1", "--jobs", "1",
                 "--out", str(out), "--no-progress"]) == 2
    assert _err_line(capsys).startswith(f"error: {out}: {problem}")


def test_log_cache_that_cannot_be_made(tiny, tmp_path, a_file, monkeypatch, capsys):
    monkeypatch.setenv("SLAM_BENCH_CACHE", str(a_file / "logs"))
    out = tmp_path / "run"
    assert main(["run", "--world", tiny, "--algo", "fake_map", "--repeats", "1", "--jobs", "1",
                 "--out", str(out), "--no-progress"]) == 2
    assert _err_line(capsys).startswith(f"error: {a_file / 'logs'}: log cache: Not a directory")
    assert not out.exists()


def test_ctrl_c_at_start_up(interrupted_main, capsys):
    import bench.__main__
    assert interrupted_main(bench.__main__, ["report", "x"]) == 130
    assert capsys.readouterr().err == "interrupted\n"


def test_log_cache_that_cannot_be_written(tiny, tmp_path, read_only_dir, monkeypatch, capsys):
    """A read-only cache that must take a new log is refused before the run writes anything."""
    monkeypatch.setenv("SLAM_BENCH_CACHE", str(read_only_dir))
    out = tmp_path / "run"
    assert main(["run", "--world", tiny, "--algo", "fake_map", "--repeats", "1", "--jobs", "1",
                 "--out", str(out), "--no-progress"]) == 2
    assert _err_line(capsys).startswith(f"error: {read_only_dir}: log cache:")
    assert not (out / "run.json").exists()
