import json
import math

import numpy as np
import pytest

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
