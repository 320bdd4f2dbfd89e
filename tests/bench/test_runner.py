"""The run loop on the tiny world with fast fake algorithms (tests/bench/fakes.py)."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bench import RunSpec, comparable, read_rows, run_benchmark
from bench import cache
from bench.rundir import read_truth
from worlds.grid import Grid
from tests.bench import fakes
from worlds.yamlio import InputError

REPO = Path(__file__).resolve().parents[2]


def _spec(tiny, **kw):
    args = dict(worlds=(tiny,), algos=("fake_map", "fake_raise", "fake_diverge"), repeats=2)
    return RunSpec(**(args | kw))


def test_rows_metrics_failures_and_maps(tiny, tmp_path):
    out = run_benchmark(_spec(tiny), tmp_path / "run", jobs=2, progress=False)
    assert out.complete and (out.ok, out.failed, out.total) == (2, 4, 6)
    rows = read_rows(tmp_path / "run")
    assert len(rows) == 6
    by = {(r["algo"], r["repeat"]): r for r in rows}
    good = by[("fake_map", 1)]
    for key in ("precision", "sensitivity", "f1", "tp", "fp", "fn", "precision_t1",
                "sensitivity_t1", "precision_t2", "sensitivity_t2", "adnn_cells", "adnn_m",
                "adnn_reverse_cells", "chamfer_cells", "align_x", "align_yaw", "ate_m",
                "ate_start_m", "rpe_trans_m", "rpe_rot_rad", "wall_time_s", "realtime_factor"):
        assert good[key] is not None, key
    assert 0 < good["precision"] <= good["precision_t1"] <= good["precision_t2"] <= 1
    assert (good["log_seed"], good["slam_seed"], good["status"]) == (0, 1, "ok")
    assert set(good["versions"]) >= {"package", "sim", "numpy", "numba"}
    assert by[("fake_raise", 0)]["status"] == "failed"
    assert by[("fake_raise", 0)]["error"] == "RuntimeError: fake failure on scan 2"
    assert by[("fake_diverge", 0)]["error"].startswith("diverged: pose")
    with np.load(tmp_path / "run" / good["map_file"]) as z:
        assert z["prob"].ndim == 2 and z["poses"].shape[1] == 3
        grid = Grid(z["prob"], float(z["resolution"]), z["origin"])
    # the surface form, under its alignment (surface_align_*: the cell form's refined onto the
    # surfaces), at the default tau, against the world's visible surfaces stored beside the
    # true map
    from metrics.surface import DEFAULT_TAU_M, classify_surface
    import worlds
    truth, surfaces = read_truth(tmp_path / "run", "tiny")
    np.testing.assert_array_equal(surfaces, worlds.load_world(tiny).visible_segments)
    expect = classify_surface(grid, surfaces, [good[f"surface_align_{k}"] for k in ("x", "y", "yaw")],
                              DEFAULT_TAU_M).counts
    assert {f"surface_align_{k}": good[f"surface_align_{k}"] for k in ("x", "y", "yaw")} == \
        pytest.approx({f"surface_align_{k}": v for k, v in expect.pop("surface_align").items()})
    assert {k: good[k] for k in expect} == pytest.approx(expect)
    assert good["surface_tau_m"] == DEFAULT_TAU_M and 0 < good["surface_precision"] <= 1
    run = json.loads((tmp_path / "run" / "run.json").read_text())
    assert run["spec"]["repeats"] == 2 and "fake_map" in run["configs"]
    # the same rows in this process as in two worker processes
    inline = run_benchmark(_spec(tiny), tmp_path / "inline", jobs=1, progress=False)
    assert inline.complete
    assert comparable(read_rows(tmp_path / "inline")) == comparable(rows)


def test_ctrl_c_then_resume_equals_uninterrupted(tiny, tmp_path):
    spec = _spec(tiny, algos=("fake_interrupt", "fake_map"), repeats=3)
    import bench.task
    bench.task._WARM.discard("fake_interrupt")
    fakes.INTERRUPT.update(after=2, built=0)  # Ctrl-C after the warm-up and one timed run
    try:
        part = run_benchmark(spec, tmp_path / "a", jobs=1, progress=False)
    finally:
        fakes.INTERRUPT.update(after=None, built=0)
    assert part.interrupted and 0 < part.ok < 6
    assert len(read_rows(tmp_path / "a")) == part.ok
    done = run_benchmark(spec, tmp_path / "a", jobs=1, progress=False, resume=True)
    assert done.complete and done.ok == 6
    full = run_benchmark(spec, tmp_path / "b", jobs=1, progress=False)
    assert comparable(read_rows(tmp_path / "a")) == comparable(read_rows(tmp_path / "b"))
    # resuming a complete run does nothing
    again = run_benchmark(spec, tmp_path / "a", jobs=1, progress=False, resume=True)
    assert again.complete and comparable(read_rows(tmp_path / "a")) == comparable(read_rows(tmp_path / "b"))
    assert full.ok == 6


@pytest.mark.parametrize("sig, jobs", [(signal.SIGKILL, 1), (signal.SIGINT, 2)])
def test_killed_process_then_resume_equals_uninterrupted(tiny, tmp_path, sig, jobs):
    cfg = tmp_path / "slow.yaml"
    cfg.write_text("delay_s: 0.15\n")
    args = ["run", "--world", tiny, "--algo", "fake_map", "--repeats", "6", "--jobs", str(jobs),
            "--config", f"fake_map={cfg}", "--no-figures"]
    code = ("import sys; import tests.bench.fakes; from bench.__main__ import main; "
            "sys.exit(main(sys.argv[1:]))")
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-c", code, *args, "--out", str(tmp_path / "killed")],
                            cwd=REPO, env=env, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    results = tmp_path / "killed" / "results.json"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if results.exists() and len(json.loads(results.read_text())["rows"]) >= 2:
            break
        time.sleep(0.05)
    proc.send_signal(sig)
    code_after = proc.wait(timeout=30)
    if sig == signal.SIGINT and code_after != 0:  # 0: it finished before the signal
        assert code_after == 130
    n = len(read_rows(tmp_path / "killed"))
    assert n >= 2
    resumed = subprocess.run([sys.executable, "-c", code, "run", "--resume", str(tmp_path / "killed"),
                              "--jobs", "1", "--no-figures", "--no-progress"],
                             cwd=REPO, env=env, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    from bench.__main__ import main
    assert main([*args, "--out", str(tmp_path / "full"), "--no-progress"]) == 0
    a, b = read_rows(tmp_path / "killed"), read_rows(tmp_path / "full")
    assert len(a) == 6 and comparable(a) == comparable(b)


def test_vary_data_records_a_log_per_repeat(tiny, tmp_path):
    spec = _spec(tiny, algos=("fake_map",), repeats=2, vary="data", seed=7)
    out = run_benchmark(spec, tmp_path / "run", jobs=1, progress=False)
    rows = read_rows(tmp_path / "run")
    assert out.complete and [(r["log_seed"], r["slam_seed"]) for r in rows] == [(7, 7), (8, 7)]
    assert rows[0]["precision"] != rows[1]["precision"] or rows[0]["ate_m"] != rows[1]["ate_m"]
    import worlds
    w = worlds.load_world(tiny)
    assert cache.log_path(w, 7, "realistic", tiny).exists()
    assert cache.log_path(w, 8, "realistic", tiny).exists()


def test_cache_key_changes_with_world_file_and_seed(tiny, tmp_path):
    import worlds
    w = worlds.load_world(tiny)
    k = cache.log_key(w, 0, "realistic", "1", tiny)
    assert k == cache.log_key(w, 0, "realistic", "1", tiny)
    assert k != cache.log_key(w, 1, "realistic", "1", tiny)
    assert k != cache.log_key(w, 0, "ideal", "1", tiny)
    assert k != cache.log_key(w, 0, "realistic", "2", tiny)
    edited = tmp_path / "tiny.yaml"
    edited.write_text(Path(tiny).read_text() + "\n# edited\n")
    assert k != cache.log_key(w, 0, "realistic", "1", edited)


def test_bad_input(tiny, tmp_path):
    with pytest.raises(InputError, match="no such world"):
        run_benchmark(_spec("nowhere_world"), tmp_path / "x", progress=False)
    run_benchmark(_spec(tiny, algos=("fake_map",), repeats=1), tmp_path / "run", jobs=1,
                  progress=False)
    with pytest.raises(InputError, match="already holds another run's results"):
        run_benchmark(_spec(tiny, algos=("fake_map",), repeats=1), tmp_path / "run", progress=False)
    with pytest.raises(InputError, match="other arguments"):
        run_benchmark(_spec(tiny, algos=("fake_map",), repeats=3), tmp_path / "run",
                      progress=False, resume=True)
    with pytest.raises(InputError, match="nothing to resume"):
        run_benchmark(_spec(tiny), tmp_path / "empty", progress=False, resume=True)


def test_dead_worker_is_reported_and_rows_kept(tiny, tmp_path):
    spec = _spec(tiny, algos=("fake_map", "fake_crash"), repeats=1)
    out = run_benchmark(spec, tmp_path / "run", jobs=2, progress=False)
    assert out.crashed and "worker process died" in out.crashed and not out.complete
    rows = read_rows(tmp_path / "run") if (tmp_path / "run" / "results.json").exists() else []
    assert all(r["algo"] == "fake_map" for r in rows)


def test_each_algorithm_is_compiled_once_before_any_task(tiny, tmp_path, monkeypatch):
    """One compile job per algorithm, costliest first, and the shared scoring job right after
    the first of them; every task after all of them."""
    import bench.runner as runner
    calls = []
    real_compile, real_scoring, real_execute = (runner.compile_algorithm, runner.compile_scoring,
                                                runner.execute)

    def compile_spy(algo, *a, **k):
        calls.append(("compile", algo))
        return real_compile(algo, *a, **k)

    def scoring_spy(world, *a, **k):
        calls.append(("scoring", world.key))
        return real_scoring(world, *a, **k)

    def execute_spy(task, *a, **k):
        calls.append(("task", task.algo))
        return real_execute(task, *a, **k)

    monkeypatch.setattr(runner, "compile_algorithm", compile_spy)
    monkeypatch.setattr(runner, "compile_scoring", scoring_spy)
    monkeypatch.setattr(runner, "execute", execute_spy)
    monkeypatch.setattr(fakes.FakeDiverge, "compile_cost_s", 1.0)
    out = run_benchmark(_spec(tiny, algos=("fake_map", "fake_diverge")), tmp_path / "run", jobs=1,
                        progress=False)
    assert out.complete
    assert calls[:3] == [("compile", "fake_diverge"), ("scoring", "tiny"), ("compile", "fake_map")]
    assert [k for k, _ in calls[3:]] == ["task"] * 4


def test_the_scoring_warm_up_maps_and_scores_the_logs_head(tiny, tmp_path, monkeypatch):
    """compile_scoring builds an output map of the log's first scans at their true poses and
    scores it with the tasks' scoring (so its kernels are the ones the tasks need)."""
    import bench.task as task_mod
    import sim
    import worlds
    from bench.runner import load_worlds
    from bench.task import WorldInfo
    seen = {}
    real_score = task_mod._score

    def score_spy(grid, truth, surfaces=None):
        seen["cells"] = int((grid.prob > 0.5).sum())
        return real_score(grid, truth, surfaces)

    monkeypatch.setattr(task_mod, "_score", score_spy)
    (key, w), = load_worlds([str(tiny)])[0].items()
    log = sim.record(w, seed=0, noise="realistic")
    info = WorldInfo(key, worlds.rasterize(w), tuple(w.bounds), surfaces=w.visible_segments)
    assert task_mod.compile_scoring(info, log) == key
    assert seen["cells"] > 0


@pytest.mark.parametrize("vary", ["slam", "data"])
def test_a_deterministic_algorithm_runs_once_per_log(tiny, tmp_path, monkeypatch, vary):
    """fake_fixed (deterministic) runs once per log and its other repeats there take that
    row, marked same_as; fake_map runs every repeat. Re-recorded logs (vary data) each run."""
    import bench.runner as runner
    ran = []
    real_execute = runner.execute

    def execute_spy(task, *a, **k):
        ran.append((task.algo, task.repeat))
        return real_execute(task, *a, **k)

    monkeypatch.setattr(runner, "execute", execute_spy)
    spec = _spec(tiny, algos=("fake_fixed", "fake_map"), repeats=3, draws=2 if vary == "slam" else 1,
                 vary=vary)
    out = run_benchmark(spec, tmp_path / "run", jobs=1, progress=False)
    assert out.complete and out.ok == out.total == (12 if vary == "slam" else 6)
    rows = {(r["algo"], r["repeat"]): r for r in read_rows(tmp_path / "run")}
    if vary == "slam":
        assert sorted(r for a, r in ran if a == "fake_fixed") == [0, 3]     # one per draw
        for rep, lead in ((1, 0), (2, 0), (4, 3), (5, 3)):
            row, first = rows[("fake_fixed", rep)], rows[("fake_fixed", lead)]
            assert row["same_as"] == lead and row["slam_seed"] == rep % 3
            assert {k: v for k, v in row.items() if k not in ("repeat", "slam_seed", "same_as")} == \
                {k: v for k, v in first.items() if k not in ("repeat", "slam_seed", "same_as")}
    else:
        assert sorted(r for a, r in ran if a == "fake_fixed") == [0, 1, 2]
    assert sorted(r for a, r in ran if a == "fake_map") == sorted(r for a, r in rows if a == "fake_map")
    assert all(r["same_as"] is None for (a, rep), r in rows.items()
               if a == "fake_map" or vary == "data" or rep % 3 == 0)
    # the copies are the rows running every repeat gives (their map_file is the run's map)
    monkeypatch.setattr(fakes.FakeFixed, "deterministic", False)
    run_benchmark(spec, tmp_path / "every", jobs=1, progress=False)
    own = ("same_as", "map_file")
    assert comparable({k: v for k, v in r.items() if k not in own}
                      for r in read_rows(tmp_path / "every")) == \
        comparable({k: v for k, v in r.items() if k not in own} for r in rows.values())


def test_compile_jobs_go_out_costliest_first_by_the_classes_estimate(monkeypatch):
    from bench.runner import RunPlan
    from slam import registry
    algos = (*registry.BUILTIN, "fake_map", "fake_raise")
    monkeypatch.setattr(fakes.FakeRaise, "compile_cost_s", 30.0)   # a plugin's own estimate
    plan = RunPlan(RunSpec(worlds=("w",), algos=algos), Path("."), {}, {}, {}, {}, {},
                   {a: registry.get(a) for a in algos}, {})
    order = plan.compile_order()
    assert order[0] == "fake_raise" and order[-1] == "fake_map"   # no estimate: 0 s, last
    shipped = [a for a in order if a in registry.BUILTIN]
    costs = [registry.get(a).compile_cost_s for a in shipped]
    assert costs == sorted(costs, reverse=True) and len(set(costs)) == len(costs) > 1


STUCK_WORLD = REPO / "tests" / "data" / "stuck_world.yaml"


def test_a_stuck_log_gives_failed_rows_with_the_reason(tmp_path, tiny):
    spec = RunSpec(worlds=(str(STUCK_WORLD), tiny), algos=("fake_map",), repeats=2)
    out = run_benchmark(spec, tmp_path / "run", jobs=1, progress=False)
    assert out.complete and (out.ok, out.failed) == (2, 2)
    rows = {(r["world"], r["repeat"]): r for r in read_rows(tmp_path / "run")}
    bad = rows[("walled", 0)]
    assert bad["status"] == "failed" and bad["map_file"] is None and "precision" not in bad
    assert bad["error"].startswith("log ended stuck after ") and bad["error"].endswith(" of 2.0 m")
    assert rows[("tiny", 1)]["status"] == "ok"
    from bench.report import write_report
    md = write_report(tmp_path / "run", figures=False).read_text()
    assert "| walled | fake_map | 2/2 | log ended stuck after" in md
    assert "– (2/2 failed)" in md                             # no average of the stuck log


def test_a_log_cut_short_by_the_time_limit_gives_failed_rows(tmp_path, tiny):
    import sim
    import worlds
    w = worlds.load_world(tiny)
    log = sim.record(w, seed=0, noise="realistic", config={"max_duration": 2.0})
    sim.write_log(log, cache.log_path(w, 0, "realistic", cache.world_file(tiny)))
    spec = RunSpec(worlds=(tiny,), algos=("fake_map",), repeats=1)
    out = run_benchmark(spec, tmp_path / "run", jobs=1, progress=False)
    assert (out.ok, out.failed) == (0, 1)
    row = read_rows(tmp_path / "run")[0]
    assert row["error"].startswith("log hit the time limit after ")
    # the same log passes once the cache holds a complete one
    cache.log_path(w, 0, "realistic", cache.world_file(tiny)).unlink()
    out = run_benchmark(spec, tmp_path / "run2", jobs=1, progress=False)
    assert (out.ok, out.failed) == (1, 0)


def test_draws_record_each_world_with_other_noise(tiny, tmp_path):
    spec = RunSpec(worlds=(tiny,), algos=("fake_map",), repeats=2, draws=3)
    out = run_benchmark(spec, tmp_path / "run", jobs=1, progress=False)
    assert out.complete and out.ok == 6
    rows = read_rows(tmp_path / "run")
    got = sorted((r["repeat"], r["draw"], r["log_seed"], r["slam_seed"]) for r in rows)
    assert got == [(0, 0, 0, 0), (1, 0, 0, 1), (2, 1, 1, 0), (3, 1, 1, 1), (4, 2, 2, 0),
                   (5, 2, 2, 1)]
    with pytest.raises(InputError, match="--vary data"):
        RunSpec(worlds=(tiny,), algos=("fake_map",), draws=2, vary="data")
    with pytest.raises(InputError, match="--draws"):
        RunSpec(worlds=(tiny,), algos=("fake_map",), draws=0)
