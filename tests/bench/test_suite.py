"""Suites: the file format, its one-line errors, and `bench run --suite` end to end."""
import json

import pytest

from bench.__main__ import main
from bench.results import read_rows
from bench.suite import load_suite, list_suites
from worlds.yamlio import InputError


def _err_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")
    return err[0]


def _suite(tmp_path, text):
    p = tmp_path / "mine.yaml"
    p.write_text(text)
    return p


def test_suite_file_names_shipped_and_relative_worlds(tmp_path, tiny):
    (tmp_path / "w").mkdir()
    (tmp_path / "w" / "tiny.yaml").write_text(open(tiny).read())
    s = load_suite(str(_suite(tmp_path, "draws: 2\nworlds: [rectangle_s, w/tiny.yaml, rectangle_s]\n")))
    assert s.name == "mine" and s.draws == 2
    assert s.worlds == ("rectangle_s", str((tmp_path / "w" / "tiny.yaml").resolve()))
    assert "general" in list_suites()


@pytest.mark.parametrize("text, msg", [
    ("worlds: [rectangle_s, rectangle_x]\n", "mine.yaml: worlds[1]: no such world 'rectangle_x' "
                                             "(did you mean"),
    ("worlds: [nowhere/w.yaml]\n", "mine.yaml: worlds[0]: world file"),
    ("worlds: [rectangle_s]\ndraw: 2\n", "mine.yaml: draw: unknown key (did you mean 'draws'?)"),
    ("worlds: [rectangle_s]\ndraws: 0\n", "mine.yaml: draws: expected an integer from 1 to 1000"),
    ("worlds: [rectangle_s]\ndraws: 1000000\n", "mine.yaml: draws: expected an integer from 1 to 1000, got 1000000"),
    ("name: ../x\nworlds: [rectangle_s]\n", "mine.yaml: name: '../x' starts with a dot"),
    ("worlds: [rectangle_s]\ndescription: &a [x, *a]\n", "not valid YAML (line 2): aliases"),
    ("worlds: [{generate: ../x, seed: 1}]\n", "mine.yaml: worlds[0].generate: unknown kind '../x' (allowed: office"),
    ("worlds: []\n", "mine.yaml: worlds: expected a non-empty list"),
    ("worlds: [{generate: office, sed: 1}]\n", "mine.yaml: worlds[0].sed: unknown key"),
    ("worlds: [{seed: 1}]\n", "mine.yaml: worlds[0].generate: missing"),
    ("worlds: [{generate: office, seed: -1}]\n", "mine.yaml: worlds[0].seed: expected an integer >= 0"),
    ("worlds: [{generate: offices, seed: 1}]\n", "mine.yaml: worlds[0].generate: unknown kind "
                                                "'offices' (did you mean 'office'?)"),
    ("worlds: [{generate: office, seed: 1, size: [1, 1]}]\n", "mine.yaml: worlds[0]:"),
])
def test_bad_suite_file_is_one_line_naming_file_and_field(tmp_path, text, msg):
    with pytest.raises(InputError) as err:
        load_suite(str(_suite(tmp_path, text)))
    assert msg in str(err.value) and "\n" not in str(err.value)


def test_bench_run_suite_errors(tmp_path, tiny, capsys):
    assert main(["run", "--suite", "generall", "--out", str(tmp_path / "o")]) == 2
    line = _err_line(capsys)
    assert "--suite generall: no such suite (shipped: " in line and " general," in line
    assert main(["run", "--suite", "general", "--world", tiny, "--out", str(tmp_path / "o")]) == 2
    assert "one of --world, --suite and --logs" in _err_line(capsys)
    bad = _suite(tmp_path, "worlds: [rectangle_s, nope]\n")
    assert main(["run", "--suite", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "mine.yaml: worlds[1]: no such world 'nope'" in _err_line(capsys)
    assert main(["run", "--suite", str(bad), "--draws", "0", "--out", str(tmp_path / "o")]) == 2
    assert "--draws: must be an integer >= 1" in _err_line(capsys)


def test_bench_run_suite_records_draws_and_reports_them(tmp_path, tiny, capsys):
    suite = _suite(tmp_path, f"name: mine\ndraws: 2\nworlds: [{tiny}]\n")
    out = tmp_path / "run"
    argv = ["run", "--suite", str(suite), "--algo", "fake_map", "--jobs", "1", "--out", str(out),
            "--no-progress", "--no-figures"]
    assert main(argv) == 0
    rows = read_rows(out)
    assert sorted((r["draw"], r["log_seed"]) for r in rows) == [(0, 0), (1, 1)]
    spec = json.loads((out / "run.json").read_text())["spec"]
    assert (spec["suite"], spec["draws"], spec["repeats"]) == ("mine", 2, 1)
    md = (out / "summary.md").read_text()
    assert "Suite: mine." in md and "## Across noise draws" in md and "## Overall" in md
    # --draws overrides the suite's; a resume needs no arguments
    assert main(["run", "--resume", str(out), "--no-progress", "--no-figures"]) == 0
    out3 = tmp_path / "run3"
    assert main([*argv[:-4], "--draws", "3", "--out", str(out3), "--no-progress",
                 "--no-figures"]) == 0
    assert len(read_rows(out3)) == 3


@pytest.mark.slow
def test_shipped_general_suite_names_the_study_worlds_loop_and_generated_worlds():
    import worlds
    s = load_suite("general")
    assert s.draws == 3 and len(s.worlds) == 20
    assert s.worlds[:8] == ("rectangle_s", "rectangle_m", "rectangle_l", "swirl_s", "swirl_m",
                            "swirl_l", "corridor", "loop")
    names = [worlds.load_world(w).name for w in s.worlds[8:]]
    assert names == [f"{k}_s{i}" for k in ("office", "warehouse", "hall", "loop") for i in range(3)]
    # generated once: a second load reuses the files
    assert load_suite("general").worlds == s.worlds


def test_a_folder_holding_a_run_is_refused_before_the_suite_is_generated(tmp_path, tiny, capsys, monkeypatch):
    """--suite into a folder that holds a run: refused at once, no world generated first."""
    out = tmp_path / "o"
    assert main(["run", "--world", tiny, "--algo", "fake_map", "--repeats", "1", "--jobs", "1",
                 "--no-progress", "--no-figures", "--out", str(out)]) == 0
    capsys.readouterr()
    import bench.suite
    monkeypatch.setattr(bench.suite, "load_suite", lambda *a, **k: pytest.fail("suite loaded"))
    assert main(["run", "--suite", "general", "--out", str(out)]) == 2
    assert "already holds another run's results" in _err_line(capsys)
