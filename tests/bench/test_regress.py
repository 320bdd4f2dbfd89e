import json

from bench.regress import compare, regress, summarize


def test_compare_flags_only_what_got_worse_beyond_tolerance():
    base = {"w/pf": {"precision": 0.80, "sensitivity": 0.70, "adnn_cells": 1.0, "ate_m": 0.05,
                     "failed": 0},
            "w/gn": {"precision": 0.9, "failed": 0}}
    cur = {"w/pf": {"precision": 0.78, "sensitivity": 0.60, "adnn_cells": 1.5, "ate_m": 0.01,
                    "failed": 1}}
    worse = compare(base, cur)
    text = "\n".join(worse)
    assert "w/pf: sensitivity dropped from 0.7 to 0.6" in text
    assert "w/pf: adnn_cells rose from 1 to 1.5" in text
    assert "w/pf: failed rose from 0 to 1" in text
    assert "precision" not in text.replace("w/gn", "")  # 0.02 drop is within 0.03
    assert "w/gn: missing from this run" in text
    assert "ate_m" not in text  # better is never a regression


def test_summarize_means_over_ok_rows():
    rows = [{"world": "w", "algo": "pf", "repeat": i, "status": "ok", "precision": p}
            for i, p in enumerate((0.5, 0.7))]
    rows.append({"world": "w", "algo": "pf", "repeat": 2, "status": "failed"})
    s = summarize(rows)["w/pf"]
    assert s["precision"] == 0.6 and s["failed"] == 1 and s["n"] == 3
    assert s["adnn_cells"] is None


def test_regress_update_then_check_then_detect(tiny, tmp_path, capsys):
    base = tmp_path / "baseline.json"
    kw = dict(worlds=[tiny], algos=["fake_map"], repeats=2, jobs=1, progress=False)
    assert regress(base, update=True, **kw) == 0
    data = json.loads(base.read_text())
    assert data["matrix"]["algos"] == ["fake_map"] and "tiny/fake_map" in data["means"]
    # the same code against its own baseline: no regression (matrix read from the file)
    assert regress(base, jobs=1, progress=False) == 0
    assert "no regression" in capsys.readouterr().out
    # a baseline that was better than we are now: exit 1 and say what got worse
    data["means"]["tiny/fake_map"]["precision"] += 0.1
    data["means"]["tiny/fake_map"]["surface_sensitivity"] += 0.1
    base.write_text(json.dumps(data))
    assert regress(base, jobs=1, progress=False) == 1
    out = capsys.readouterr().out
    assert "regression: 2 metric(s) got worse" in out and "tiny/fake_map: precision dropped" in out
    assert "tiny/fake_map: surface_sensitivity dropped" in out


def test_a_baseline_from_before_the_surface_form_is_checked_without_it(tiny, tmp_path, capsys):
    """A baseline written before the surface form (no surface_* means or tolerances): the
    surface keys are skipped with a note, everything else is checked as before."""
    base = tmp_path / "baseline.json"
    kw = dict(worlds=[tiny], algos=["fake_map"], repeats=1, jobs=1, progress=False)
    assert regress(base, update=True, **kw) == 0
    data = json.loads(base.read_text())
    assert data["tolerances"]["surface_precision"] == ["drop", 0.03]
    assert data["means"]["tiny/fake_map"]["surface_precision"] > 0
    for part in (data["tolerances"], *data["means"].values()):
        for k in [k for k in part if k.startswith("surface_")]:
            del part[k]
    base.write_text(json.dumps(data))
    capsys.readouterr()
    assert regress(base, jobs=1, progress=False) == 0
    out = capsys.readouterr().out
    assert ("metrics the baseline has no value of (not checked; refresh it with --update): "
            "surface_precision, surface_sensitivity") in out
    assert "no regression" in out
    data["means"]["tiny/fake_map"]["precision"] += 0.1      # the old keys are still checked
    base.write_text(json.dumps(data))
    assert regress(base, jobs=1, progress=False) == 1
    assert "tiny/fake_map: precision dropped" in capsys.readouterr().out


def test_committed_baseline_is_the_default_matrix():
    from bench.regress import BASELINE_PATH, DEFAULT_REPEATS, DEFAULT_WORLDS, _load_baseline
    data = _load_baseline(BASELINE_PATH)
    m = data["matrix"]
    assert m["worlds"] == list(DEFAULT_WORLDS) and m["repeats"] == DEFAULT_REPEATS
    assert set(m["algos"]) >= {"pf", "gn", "graph", "oracle"}
    assert set(data["means"]) == {f"{w}/{a}" for w in m["worlds"] for a in m["algos"]}
