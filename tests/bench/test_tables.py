import csv
import io

import pytest

from bench.tables import aggregate, algo_order, mean_std, summary_csv, summary_markdown


def _rows():
    rows = []
    for w, base in (("swirl_s", 1.0), ("rectangle_s", 2.0)):
        for a, off in (("oracle", 0.0), ("pf", 0.5), ("gn", 1.0)):
            for r, d in enumerate((-0.1, 0.1)):
                rows.append({"world": w, "algo": a, "repeat": r, "status": "ok",
                             "adnn_cells": base + off + d, "precision": 0.8 + d,
                             "sensitivity": 0.7, "precision_t1": 0.9, "sensitivity_t1": 0.95,
                             "ate_m": 0.05, "rpe_trans_m": 0.01, "realtime_factor": 10.0})
    rows.append({"world": "swirl_s", "algo": "pf", "repeat": 2, "status": "failed",
                 "error": "diverged: boom"})
    return rows


def test_mean_std_is_sample_std_over_finite():
    m, s, n = mean_std([1.0, 3.0, None, float("nan")])
    assert (m, n) == (2.0, 2) and s == pytest.approx(2 ** 0.5)
    assert mean_std([4.0]) == (4.0, 0.0, 1)
    assert mean_std([])[2] == 0


def test_aggregate_counts_failures_and_uses_ok_rows():
    agg = aggregate(_rows())
    g = agg[("swirl_s", "pf")]
    assert (g["n"], g["failed"]) == (3, 1)
    assert g["adnn_cells"][0] == pytest.approx(1.5)
    assert g["errors"] == ["diverged: boom"]


def test_algo_order_puts_oracle_last():
    assert algo_order(["oracle", "graph", "zz", "pf", "gn"]) == ["pf", "gn", "graph", "zz", "oracle"]


def test_markdown_has_the_study_layout():
    run = {"worlds": {"swirl_s": {}, "rectangle_s": {}}, "spec": {"repeats": 2}}
    md = summary_markdown(_rows(), run)
    lines = md.splitlines()
    t1 = lines.index("## Table 1: ADNN (cells), mean ± std")
    assert lines[t1 + 2] == "| world | pf | gn | oracle (ceiling) |"
    # worlds are rows, in the order the run named them; cells mean ± std
    assert lines[t1 + 4].startswith("| swirl_s | 1.50 ± 0.14 (1/3 failed) | 2.00 ± 0.14 | 1.00 ± 0.14 |")
    assert lines[t1 + 5].startswith("| rectangle_s | 2.50 ± 0.14 |")
    t2 = next(i for i, l in enumerate(lines) if l.startswith("## Table 2: precision"))
    assert lines[t2 + 2] == ("| world | pf P | pf S | gn P | gn S | oracle (ceiling) P | "
                             "oracle (ceiling) S |")
    assert "0.800 ± 0.141" in lines[t2 + 4]
    assert "## Table 2b: precision and sensitivity at a tolerance of 1 cell" in md
    assert "## Failures" in md and "diverged: boom" in md


def test_csv_one_line_per_world_and_algo():
    rows = list(csv.DictReader(io.StringIO(summary_csv(_rows()))))
    assert len(rows) == 6
    pf = next(r for r in rows if r["world"] == "swirl_s" and r["algo"] == "pf")
    assert pf["n"] == "3" and pf["failed"] == "1"
    assert float(pf["adnn_cells_mean"]) == pytest.approx(1.5)
    assert pf["ate_start_m_mean"] == ""
