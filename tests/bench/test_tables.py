import csv
import io

import pytest

from bench.tables import aggregate, algo_order, mean_std, summary_csv, summary_markdown
from metrics.surface import DEFAULT_TAU_M

TAU = f"tau = {DEFAULT_TAU_M:g} m"


def _surface(precision, sensitivity):
    """The surface form's keys of a row of a simulated world."""
    return {"surface_precision": precision, "surface_sensitivity": sensitivity,
            "surface_f1": 2 * precision * sensitivity / (precision + sensitivity),
            "surface_tau_m": DEFAULT_TAU_M}


def _rows(surface=False):
    """Two study worlds x (oracle, pf, gn) x 2 repeats, one failed pf row; surface=True: the
    rows of simulated worlds (surface form 0.1 above the cell form)."""
    rows = []
    for w, base in (("swirl_s", 1.0), ("rectangle_s", 2.0)):
        for a, off in (("oracle", 0.0), ("pf", 0.5), ("gn", 1.0)):
            for r, d in enumerate((-0.1, 0.1)):
                rows.append({"world": w, "algo": a, "repeat": r, "status": "ok",
                             "adnn_cells": base + off + d, "precision": 0.8 + d,
                             "sensitivity": 0.7, "precision_t1": 0.9, "sensitivity_t1": 0.95,
                             "ate_m": 0.05, "rpe_trans_m": 0.01, "realtime_factor": 10.0,
                             **(_surface(0.9 + d, 0.8) if surface else {})})
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
    # a plugin mapping with the true poses (the fakes: uses_ground_truth) is a ceiling too
    assert algo_order(["fake_map", "zz", "oracle", "pf"]) == ["pf", "zz", "oracle", "fake_map"]


def test_markdown_has_the_study_layout():
    run = {"worlds": {"swirl_s": {}, "rectangle_s": {}}, "spec": {"repeats": 2}}
    md = summary_markdown(_rows(surface=True), run)
    lines = md.splitlines()
    t1 = lines.index("## Table 1: ADNN (cells), mean ± std")
    assert lines[t1 + 2] == "| world | pf | gn | oracle (ceiling) |"
    # worlds are rows, in the order the run named them; cells mean ± std
    assert lines[t1 + 4].startswith("| swirl_s | 1.50 ± 0.14 (1/3 failed) | 2.00 ± 0.14 | 1.00 ± 0.14 |")
    assert lines[t1 + 5].startswith("| rectangle_s | 2.50 ± 0.14 |")
    # Table 2: the surface form, labelled with its tau; the study's cell rule in its own table
    t2 = lines.index("## Table 2: precision (P) and sensitivity (S) of the walls, surface form, "
                     "mean ± std")
    assert lines[t2 + 2].startswith(f"Main form: surface, {TAU} (metrics.surface")
    assert "(cell)" not in lines[t2 + 2]
    assert lines[t2 + 4] == ("| world | pf P | pf S | gn P | gn S | oracle (ceiling) P | "
                             "oracle (ceiling) S |")
    assert lines[t2 + 6].startswith("| swirl_s | 0.900 ± 0.141 (1/3 failed) | 0.800 ± 0.000 |")
    tc = lines.index("## Table 2, the study's cell rule: precision (P) and sensitivity (S) of "
                     "occupied cells, exact cell, mean ± std")
    assert lines[tc + 4].startswith("| swirl_s | 0.800 ± 0.141 (1/3 failed) | 0.700 ± 0.000 |")
    assert "## Table 2b, the study's cell rule at a tolerance of 1 cell" in md
    assert "## Failures" in md and "diverged: boom" in md
    assert "(cell)" not in md


def test_a_raster_only_truth_shows_the_cell_form_marked():
    """Rows without the surface form (a truth that is only a raster): the main table shows the
    study's cell rule, marked (cell), and says so."""
    rows = _rows(surface=True)
    rows = [r if r["world"] == "swirl_s" else {k: v for k, v in r.items()
                                               if not k.startswith("surface_")} for r in rows]
    md = summary_markdown(rows)
    lines = md.splitlines()
    t2 = next(i for i, line in enumerate(lines) if line.startswith("## Table 2: precision"))
    assert "Worlds without the surfaces (rectangle_s: a truth that is only a raster)" in lines[t2 + 2]
    assert lines[t2 + 6].startswith("| swirl_s | 0.900 ± 0.141 (1/3 failed) | 0.800 ± 0.000 |")
    assert lines[t2 + 7].startswith("| rectangle_s | 0.800 ± 0.141 (cell) | 0.700 ± 0.000 (cell) |")
    # a world with rows of both kinds (a run resumed after the surface form came) is one form
    rows = _rows(surface=True) + [{"world": "swirl_s", "algo": "gn", "repeat": 5, "status": "ok",
                                   "precision": 0.1, "sensitivity": 0.1}]
    lines = summary_markdown(rows).splitlines()
    t2 = next(i for i, line in enumerate(lines) if line.startswith("## Table 2: precision"))
    assert lines[t2 + 6].startswith("| swirl_s | 0.800 ± 0.141 (cell) (1/3 failed) |")


def test_csv_one_line_per_world_and_algo():
    rows = list(csv.DictReader(io.StringIO(summary_csv(_rows(surface=True)))))
    assert len(rows) == 6
    pf = next(r for r in rows if r["world"] == "swirl_s" and r["algo"] == "pf")
    assert pf["n"] == "3" and pf["failed"] == "1"
    assert float(pf["adnn_cells_mean"]) == pytest.approx(1.5)
    assert float(pf["surface_precision_mean"]) == pytest.approx(0.9)
    assert float(pf["surface_sensitivity_mean"]) == pytest.approx(0.8)
    assert float(pf["precision_mean"]) == pytest.approx(0.8)
    assert pf["ate_start_m_mean"] == ""
    cell_only = list(csv.DictReader(io.StringIO(summary_csv(_rows()))))
    assert cell_only[0]["surface_precision_mean"] == "" and cell_only[0]["precision_mean"] != ""


def _draw_rows(surface=()):
    """Two worlds x (pf, oracle) x 3 draws x 2 repeats; pf's draw 2 on 'hall' failed; the
    worlds in `surface` have the surface form, 0.1 below the cell form."""
    rows = []
    for w in ("swirl_s", "hall"):
        for a, p in (("pf", 0.7), ("oracle", 0.95)):
            for d in range(3):
                for r in range(2):
                    prec = p + 0.1 * d + 0.02 * r
                    row = {"world": w, "algo": a, "repeat": 2 * d + r, "draw": d, "status": "ok",
                           "precision": prec, "sensitivity": p,
                           "adnn_cells": 1.0, "ate_m": 0.1,
                           **(_surface(prec - 0.1, p - 0.1) if w in surface else {})}
                    if (w, a, d) == ("hall", "pf", 2):
                        row = {"world": w, "algo": a, "repeat": 2 * d + r, "draw": d,
                               "status": "failed", "error": "log ended stuck after 1.0 m of 9.0 m"}
                    rows.append(row)
    return rows


def test_over_draws_averages_each_draw_first():
    from bench.tables import over_draws
    st = over_draws(_draw_rows(), "precision")
    m, s, n = st[("swirl_s", "pf")]
    assert n == 3 and m == pytest.approx(0.81) and s == pytest.approx(0.1)
    m, s, n = st[("hall", "pf")]                   # the stuck draw is left out
    assert n == 2 and m == pytest.approx(0.76)


def test_summary_of_a_run_with_draws_has_ceiling_gap_and_overall_tables():
    run = {"spec": {"suite": "mine", "draws": 3, "repeats": 2, "seed": 0, "vary": "slam",
                    "noise": "realistic"}, "worlds": {"swirl_s": {}, "hall": {}}}
    md = summary_markdown(_draw_rows(), run)
    assert "Suite: mine." in md and "Noise draws per world: 3 (log seeds 0..2)" in md
    assert "## Across noise draws" in md
    # no surfaces: the study's cell rule, marked
    assert "| swirl_s | 0.810 ± 0.100 (cell) | 0.700 ± 0.000 (cell) | 1.060 ± 0.100 (cell) |" in md
    assert "0.760 ± 0.071 (cell) (2/6 failed)" in md
    assert "| swirl_s | +0.250 | +0.250 |" in md             # oracle − pf
    # overall: pf's mean over worlds of (0.81, 0.76); gap (0.25 + 0.25) / 2
    assert "| pf | 2/2 | 0.785 | 0.700 | +0.250 | +0.250 | 1.00 | 0.100 | 2/12 |" in md
    assert "| oracle (ceiling) | 2/2 |" in md
    # swirl_s simulated: its draws, gaps and share of the overall means in the surface form
    md = summary_markdown(_draw_rows(surface=("swirl_s",)), run)
    assert (f"## Across noise draws: precision (P) and sensitivity (S) (surface, {TAU}), mean "
            "± std over draws") in md
    assert "| swirl_s | 0.710 ± 0.100 | 0.600 ± 0.000 | 0.960 ± 0.100 | 0.850 ± 0.000 |" in md
    assert "| hall | 0.760 ± 0.071 (cell) (2/6 failed) |" in md
    assert "| swirl_s | +0.250 | +0.250 |" in md
    # pf: P (0.71 + 0.76) / 2, S (0.6 + 0.7) / 2
    assert "| pf | 2/2 | 0.735 | 0.650 | +0.250 | +0.250 | 1.00 | 0.100 | 2/12 |" in md


def test_study_numbers_stand_beside_ours_on_the_study_worlds():
    md = summary_markdown(_rows(surface=True))
    assert "## Beside the reference study" in md
    # swirl_s: Gmapping 0.39 / 0.46 beside pf's 0.800 / 0.700 by the study's cell rule, then
    # pf's surface form 0.900 / 0.800; Hector 0.89 / 1.00 beside gn
    assert (f"| world | Gmapping (study) | pf (study's cell rule) | pf (surface, {TAU}) | "
            "Hector (study) |") in md
    assert ("| swirl_s | 0.39 / 0.46 | 0.800 ± 0.141 / 0.700 ± 0.000 | 0.900 ± 0.141 / "
            "0.800 ± 0.000 | 0.89 / 1.00 |") in md
    assert "| rectangle_s | 0.44 | 2.50 ± 0.14 | 0.14 | 3.00 ± 0.14 |" in md
    # without the surfaces only the cell rule stands beside the study
    md = summary_markdown(_rows())
    assert "| swirl_s | 0.39 / 0.46 | 0.800 ± 0.141 / 0.700 ± 0.000 | – | 0.89 / 1.00 |" in md
    # no study world, no study table
    other = [dict(r, world="hall") for r in _rows()]
    assert "reference study" not in summary_markdown(other)
