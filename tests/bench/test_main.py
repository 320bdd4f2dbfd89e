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
    (["--repeats", "0"], "--repeats must be >= 1"),
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
    assert "| world | fake_map | fake_raise |" in md and "| tiny | " in md
    assert (out / "summary.csv").exists()
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
