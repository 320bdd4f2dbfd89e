import json
import math
import re

import numpy as np
import pytest

from bench.__main__ import main as bench_main
from bench.results import ResultStore, comparable, jsonable, read_rows
from worlds.yamlio import InputError


def _row(w, a, r, **kw):
    return {"world": w, "algo": a, "repeat": r, "status": "ok", **kw}


def test_rows_persist_sorted_and_replace(tmp_path):
    s = ResultStore(tmp_path)
    s.add(_row("b", "pf", 1, adnn_cells=np.float64(1.5)))
    s.add(_row("a", "pf", 0, adnn_cells=float("nan")))
    s.add(_row("b", "pf", 0))
    s.add(_row("b", "pf", 1, adnn_cells=2.0))  # same key: replaced
    rows = read_rows(tmp_path)
    assert [(r["world"], r["repeat"]) for r in rows] == [("a", 0), ("b", 0), ("b", 1)]
    assert rows[0]["adnn_cells"] is None  # NaN is not JSON
    assert rows[2]["adnn_cells"] == 2.0
    again = ResultStore(tmp_path)
    assert len(again) == 3 and ("b", "pf", 1) in again
    # no temporary files left beside it
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json"]


def test_comparable_drops_timing_only():
    a = [_row("w", "pf", 0, precision=0.5, wall_time_s=1.0, realtime_factor=3.0,
              slam_stats={"update_time_max_s": 0.1, "scans": 5})]
    b = [_row("w", "pf", 0, precision=0.5, wall_time_s=9.0, realtime_factor=1.0,
              slam_stats={"update_time_max_s": 0.7, "scans": 5})]
    assert comparable(a) == comparable(b)
    b[0]["precision"] = 0.6
    assert comparable(a) != comparable(b)


def test_jsonable():
    out = jsonable({"a": np.int64(3), "b": [np.float32(0.5), math.inf], "c": (1, 2)})
    assert out == {"a": 3, "b": [0.5, None], "c": [1, 2]}
    json.dumps(out)


def test_bad_results_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_rows(tmp_path)
    (tmp_path / "results.json").write_text("{not json")
    with pytest.raises(InputError, match="not valid JSON"):
        read_rows(tmp_path)
    (tmp_path / "results.json").write_text('{"x": 1}')
    with pytest.raises(InputError, match="no 'rows'"):
        read_rows(tmp_path)


# --- hostile results files: one line naming the file and the field -----------------------

def _write(path, content):
    path.write_bytes(content if isinstance(content, bytes) else json.dumps(content).encode()
                     if not isinstance(content, str) else content.encode())
    return path


def _rows_file(*rows):
    return {"format": 1, "rows": list(rows)}


DEEP = '{"rows": ' + "[" * 100_000 + "]" * 100_000 + "}"          # json: RecursionError
DEEP_150 = '{"rows": [' + '{"a": ' * 150 + "1" + "}" * 150 + "]}"  # parses; recursion waits
HOSTILE = [
    (bytes(range(256)) * 4, "not a text file (byte 128 is not UTF-8)"),
    (DEEP, "JSON nested deeper than 100 levels"),
    (DEEP_150, "JSON nested deeper than 100 levels"),
    ('{"rows": [{"repeat": 1' + "0" * 5000 + "}]}", "not valid JSON: Exceeds the limit"),
    ([_row("w", "pf", 0)], "not a bench results file (expected a JSON object, got list)"),
    (_rows_file(5), "rows[0]: expected a mapping (a row), got 5"),
    (_rows_file(_row("w", "pf", 0), [1]), "rows[1]: expected a mapping (a row), got [1]"),
    (_rows_file(_row("w", "pf", "x")), "rows[0].repeat: expected an integer in [0, 2**63), got 'x'"),
    (_rows_file(_row("w", "pf", -1)), "rows[0].repeat: expected an integer in [0, 2**63), got -1"),
    (_rows_file(_row("w", "pf", True)), "rows[0].repeat: expected an integer"),
    (_rows_file(_row("w", "pf", 2 ** 70)), "rows[0].repeat: expected an integer"),
    (_rows_file(_row(5, "pf", 0)), "rows[0].world: expected a name, got 5"),
    (_rows_file(_row("../x", "pf", 0)), "rows[0].world: '../x' starts with a dot"),
    (_rows_file(_row("w", "/abs/x", 0)), "rows[0].algo: '/abs/x' holds characters other than"),
    (_rows_file(_row("w", "a/b", 0)), "rows[0].algo: 'a/b' holds characters other than"),
    (_rows_file(_row("..", "pf", 0)), "rows[0].world: '..' starts with a dot"),
    (_rows_file(_row("", "pf", 0)), "rows[0].world: '' is empty"),
    (_rows_file(_row("wörld", "pf", 0)), "rows[0].world: 'wörld' holds characters other than"),
    (_rows_file(_row("w", "pf", 0, log_seed="7")), "rows[0].log_seed: expected an integer"),
    (_rows_file(_row("w", "pf", 0, draw=1.5)), "rows[0].draw: expected an integer"),
    (_rows_file(_row("w", "pf", 0, status="fine")), "rows[0].status: expected one of ok, failed"),
    (_rows_file(_row("w", "pf", 0, error=["x"])), "rows[0].error: expected text or null"),
    (_rows_file(_row("w", "pf", 0, precision="x")), "rows[0].precision: expected a number or null"),
    (_rows_file(_row("w", "pf", 0, ate_m=True)), "rows[0].ate_m: expected a number or null"),
    (_rows_file(_row("w", "pf", 0, map_file="../X")),
     "rows[0].map_file: '../X' is not a path inside the run folder"),
    (_rows_file(_row("w", "pf", 0, map_file="/etc/x.npz")),
     "rows[0].map_file: '/etc/x.npz' is not a path inside the run folder"),
    (_rows_file(_row("w", "pf", 0, map_file="maps//x")), "rows[0].map_file"),
    (_rows_file(_row("w", "pf", 0), _row("w", "pf", 0)), "rows[1]: w/pf/0 again (also rows[0])"),
    ({"format": 2, "rows": []}, "format: expected 1, got 2"),
]


@pytest.mark.parametrize("content, message", HOSTILE)
def test_hostile_results_files_are_one_line_naming_the_field(tmp_path, content, message):
    p = _write(tmp_path / "results.json", content)
    with pytest.raises(InputError) as err:
        read_rows(tmp_path)
    text = str(err.value)
    assert text.startswith(f"{p}: ") and message in text and "\n" not in text
    assert len(text) < 400


def test_rows_the_runner_writes_pass_the_checks(tmp_path):
    rows = [_row("tiny", "oracle", 0, draw=0, log_seed=3, slam_seed=None, error=None,
                 map_file="maps/tiny/oracle/0.npz", precision=0.5, ate_m=None, noise="noise.yaml",
                 slam_stats={"scans": 5}, versions={"numpy": "2"})]
    _write(tmp_path / "results.json", _rows_file(*rows))
    assert read_rows(tmp_path) == rows


def test_a_large_file_is_refused_before_it_is_read(tmp_path, monkeypatch):
    import bench.results
    monkeypatch.setattr(bench.results, "MAX_JSON_BYTES", 1000)
    p = _write(tmp_path / "results.json", _rows_file(*[_row("w", "pf", i) for i in range(20)]))
    with pytest.raises(InputError, match=re.escape(f"{p}: {p.stat().st_size:,} bytes, more than "
                                                   "the 1,000 a bench results file may have")):
        read_rows(tmp_path)


# --- every command that reads a run's files ------------------------------------------------

@pytest.fixture(scope="module")
def shards(tmp_path_factory):
    """Two shards of a fake_map run on the tiny world (made once, copied per test)."""
    from tests.bench.conftest import TINY
    base = tmp_path_factory.mktemp("shards")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SLAM_BENCH_CACHE", str(tmp_path_factory.getbasetemp() / "logcache"))
        for k in (1, 2):
            assert bench_main(["run", "--world", TINY, "--algo", "fake_map", "--repeats", "2",
                               "--jobs", "1", "--shard", f"{k}/2", "--no-progress",
                               "--no-figures", "--out", str(base / f"s{k}")]) == 0
    return base


def _one_error_line(capsys) -> str:
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    return lines[0]


BAD_FILES = {
    "binary": (bytes(range(256)) * 4, "not a text file"),
    "deep": (DEEP, "nested deeper than 100 levels"),
    "row": (_rows_file(5), "rows[0]: expected a mapping"),
    "repeat": (_rows_file(_row("tiny", "fake_map", "x")), "rows[0].repeat: expected an integer"),
    "world": (_rows_file(_row(5, "fake_map", 0)), "rows[0].world: expected a name"),
    "map_file": (_rows_file(_row("tiny", "fake_map", 0, map_file="../X")),
                 "rows[0].map_file: '../X' is not a path inside"),
}


@pytest.mark.parametrize("command", ["merge", "resume", "add"])
@pytest.mark.parametrize("bad", list(BAD_FILES))
def test_commands_refuse_a_hostile_results_file_in_one_line(shards, tmp_path, capsys, command, bad):
    import shutil
    s1 = shutil.copytree(shards / "s1", tmp_path / "s1")
    s2 = shutil.copytree(shards / "s2", tmp_path / "s2")
    content, message = BAD_FILES[bad]
    target = _write(s2 / "results.json", content)
    before = target.read_bytes()
    argv = {"merge": ["merge", str(s1), str(s2), "--out", str(tmp_path / "m"), "--no-figures"],
            "resume": ["run", "--resume", str(s2), "--jobs", "1", "--no-progress", "--no-figures"],
            "add": ["add", str(s2), "--world", "tiny", "--algo", "outside", "--map",
                    str(_a_map(tmp_path)), "--no-figures"]}[command]
    assert bench_main(argv) == 2
    line = _one_error_line(capsys)
    assert f"{target}: " in line and message in line
    assert target.read_bytes() == before
    assert not (tmp_path / "m" / "results.json").exists()


@pytest.mark.parametrize("content, message", [
    (bytes(range(256)) * 4, "not a text file"),
    (DEEP, "nested deeper than 100 levels"),
    ({"spec": 5, "worlds": {}}, "spec: expected a mapping"),
    ({"spec": {"worlds": 5, "algos": ["a"]}, "worlds": {}}, "spec: --world must be a list of names, got 5"),
    ({"spec": {"worlds": ["w"], "algos": ["a"], "repeats": "x"}, "worlds": {}},
     "spec: --repeats must be an integer from 1 to 10,000, got 'x'"),
    ({"spec": {"worlds": ["w"], "algos": ["a"]}, "worlds": ["w"]}, "worlds: expected a mapping"),
    ({"spec": {"worlds": ["w"], "algos": ["a"]}, "worlds": {"../w": {}}},
     "worlds: '../w' starts with a dot"),
])
@pytest.mark.parametrize("command", ["merge", "add"])
def test_commands_refuse_a_hostile_run_file_in_one_line(shards, tmp_path, capsys, command,
                                                        content, message):
    import shutil
    s1 = shutil.copytree(shards / "s1", tmp_path / "s1")
    s2 = shutil.copytree(shards / "s2", tmp_path / "s2")
    target = _write(s2 / "run.json", content)
    argv = {"merge": ["merge", str(s1), str(s2), "--out", str(tmp_path / "m"), "--no-figures"],
            "add": ["add", str(s2), "--world", "tiny", "--algo", "outside", "--map",
                    str(_a_map(tmp_path)), "--no-figures"]}[command]
    before = (s2 / "results.json").read_bytes()
    assert bench_main(argv) == 2
    line = _one_error_line(capsys)
    assert f"{target}: " in line and message in line
    assert (s2 / "results.json").read_bytes() == before
    assert not (tmp_path / "m" / "results.json").exists()


@pytest.mark.parametrize("content, message", [
    (bytes(range(256)) * 4, "not a text file"),
    (DEEP, "nested deeper than 100 levels"),
    ({"matrix": {"repeats": "x"}, "means": {}}, "matrix.repeats: expected an integer >= 1"),
    ({"matrix": {"worlds": "tiny"}, "means": {}}, "matrix.worlds: expected a list of names"),
    ({"matrix": {}, "means": {"w/pf": {"precision": "x"}}},
     "means.w/pf.precision: expected a number or null, got 'x'"),
    ({"matrix": {}, "means": {"w/pf": 5}}, "means.w/pf: expected a mapping"),
    ({"matrix": {}, "means": {}, "tolerances": {"ate_m": ["up", 1]}},
     "tolerances.ate_m: expected [\"drop\" or \"rise\", a number]"),
])
def test_regress_refuses_a_hostile_baseline_in_one_line(tmp_path, capsys, content, message):
    from tests.bench.conftest import TINY
    base = _write(tmp_path / "baseline.json", content)
    # a small matrix: a reader that let the file through runs quickly and fails the test
    assert bench_main(["regress", "--baseline", str(base), "--jobs", "1", "--world", TINY,
                       "--algo", "fake_map", "--repeats", "1", "--out", str(tmp_path / "r")]) == 2
    line = _one_error_line(capsys)
    assert f"{base}: " in line and message in line


def _a_map(tmp_path):
    """A small map_server pair to add (its scores do not matter here)."""
    from worlds import Grid, write_map
    prob = np.full((20, 20), 0.2)
    prob[5, :] = 0.9
    path = tmp_path / "a_map.yaml"
    if not path.exists():
        write_map(Grid(prob, 0.05, np.zeros(3)), path)
    return path


def test_a_relative_run_folder_is_written_in_place(tmp_path, monkeypatch):
    """The write is checked against the folder (root=): a relative folder must not be joined
    to itself (runs/x/runs/x/results.json)."""
    monkeypatch.chdir(tmp_path)
    store = ResultStore("runs/x")
    store.add(_row("w", "pf", 0))
    assert read_rows(tmp_path / "runs" / "x")[0]["world"] == "w"
    assert sorted(p.name for p in (tmp_path / "runs" / "x").iterdir()) == ["results.json"]
