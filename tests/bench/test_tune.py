"""bench tune: search spaces checked against the configs, trials on a tiny suite, pruning,
an interrupted tune resuming to the same best trial, and the CLI's one-line errors."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from worlds.yamlio import InputError
from bench.__main__ import main
from bench.plan import load_config_checked
from bench.tune import TuneSpec, load_space, tune
from bench.tune.space import overrides_of
from tests.bench.fakes import INTERRUPT

TINY = str(Path(__file__).with_name("tiny_world.yaml"))


def _suite(tmp_path: Path, name: str, worlds: int = 1, draws: int = 2) -> str:
    """A suite of `worlds` copies of the tiny world (named tiny0, tiny1, ...)."""
    text = Path(TINY).read_text()
    files = []
    for k in range(worlds):
        f = tmp_path / f"tiny{k}.yaml"
        f.write_text(text.replace("name: tiny", f"name: tiny{k}", 1))
        files.append(str(f))
    path = tmp_path / f"{name}.yaml"
    lines = [f"name: {name}", f"draws: {draws}", "worlds:"] + [f"  - {f}" for f in files]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def _space(tmp_path: Path, text: str, name: str = "space.yaml") -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


NOISE_SPACE = "params:\n  pose_noise_m: {low: 0.001, high: 0.05, log: true}\n"


@pytest.mark.parametrize("text, message", [
    ("params:\n  particle: {low: 10, high: 50}\n", "params.particle: not a config field of pf (did you mean 'particles'?)"),
    ("params:\n  particles: {low: 50, high: 10}\n", "params.particles: low (50) must be below high (10)"),
    ("params:\n  particles: {low: 10.5, high: 50}\n", "params.particles.low: the field is an integer"),
    ("params:\n  motion.srr: {low: 0, high: 0.3, log: true}\n", "params.motion.srr: a log-scale range needs low > 0"),
    ("params:\n  motion.srr: {low: 0.1}\n", "params.motion.srr.high: missing"),
    ("params:\n  motion.srr: {low: 0.1, high: 0.2, scale: log}\n", "params.motion.srr.scale: unknown key"),
    ("params:\n  particles: {choices: [10, x]}\n", "params.particles: 'x' is refused"),
    ("params:\n  resample_threshold: {low: 0.1, high: 2.0}\n", "params.resample_threshold: 2.0 is refused: resample_threshold must lie in [0, 1]"),
    ("params: []\n", "params: expected a mapping of config fields"),
    ("algo: graph\nparams:\n  particles: {low: 10, high: 50}\n", "algo: the space is written for 'graph'"),
    ("parms:\n  particles: {low: 10, high: 50}\n", "parms: unknown key (did you mean 'params'?)"),
])
def test_a_bad_space_names_its_file_and_field(tmp_path, text, message):
    path = _space(tmp_path, text)
    with pytest.raises(InputError) as err:
        load_space(path, "pf")
    assert str(err.value).startswith(f"{path}: ")
    assert message in str(err.value)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("algo", ["graph", "pf", "gn"])
def test_every_shipped_space_loads_and_its_bounds_are_valid_configs(algo):
    space = load_space(None, algo)
    assert len(space.params) >= 5
    for p in space.params:
        for v in ((p.low, p.high) if p.kind != "choice" else p.choices):
            load_config_checked(algo, None, overrides_of({p.path: v}))


def test_a_tune_finds_a_better_config_and_judges_it_on_the_holdout(tmp_path):
    out = tmp_path / "tune"
    spec = TuneSpec(algo="fake_map", suite=_suite(tmp_path, "dev"),
                    holdout=_suite(tmp_path, "hold", draws=1),
                    space=_space(tmp_path, NOISE_SPACE), trials=6, objective="ate")
    outcome = tune(spec, out, jobs=1, progress=False)
    assert outcome.complete == 6 and not outcome.interrupted
    best = load_config_checked("fake_map", str(out / "best.yaml"))
    assert best.pose_noise_m < 0.01           # the default's noise is beaten
    summary = (out / "summary.md").read_text()
    assert "### Hold-out suite" in summary and "### Dev suite" in summary
    assert (out / "figures" / "objective.png").is_file()
    best_trial = json.loads((out / "summary.json").read_text())["best_trial"]
    assert (out / "holdout" / f"trial_{best_trial:04d}" / "results.json").is_file()
    data = json.loads((out / "summary.json").read_text())
    assert data["best_params"]["pose_noise_m"] == pytest.approx(best.pose_noise_m)


def test_an_interrupted_tune_resumes_to_the_same_best_trial(tmp_path):
    def spec(trials):
        return TuneSpec(algo="fake_interrupt", suite=_suite(tmp_path, "dev", worlds=2, draws=1),
                        space=_space(tmp_path, NOISE_SPACE), trials=trials, objective="ate")
    whole = tune(spec(7), tmp_path / "whole", jobs=1, progress=False)
    INTERRUPT.update(after=7, built=0)       # a Ctrl-C a few trials in, part way through one
    try:
        cut = tune(spec(7), tmp_path / "cut", jobs=1, progress=False)
    finally:
        INTERRUPT.update(after=None, built=0)
    assert cut.interrupted
    rest = tune(spec(7), tmp_path / "cut", jobs=1, progress=False, resume=True)
    assert not rest.interrupted
    assert (rest.best_number, rest.best_value) == (whole.best_number, whole.best_value)
    assert ((tmp_path / "cut" / "best.yaml").read_text()
            == (tmp_path / "whole" / "best.yaml").read_text())
    # the interrupted trial kept its number and the rows it had finished
    assert sorted(p.name for p in (tmp_path / "cut" / "trials").iterdir()) == [
        f"{n:04d}" for n in range(7)]


def test_the_pruner_stops_trials_that_start_worse(tmp_path):
    spec = TuneSpec(algo="fake_map", suite=_suite(tmp_path, "dev", worlds=4, draws=1),
                    space=_space(tmp_path, "params:\n  pose_noise_m: {low: 0.0005, high: 0.2, "
                                           "log: true}\n"),
                    trials=14, objective="ate")
    outcome = tune(spec, tmp_path / "t", jobs=1, progress=False)
    assert outcome.pruned >= 1
    assert outcome.complete + outcome.pruned == 14
    summary = (tmp_path / "t" / "summary.md").read_text()
    assert "| pruned at world " in summary


def test_a_trial_that_fails_where_the_defaults_ran_is_failed_not_averaged(tmp_path):
    space = _space(tmp_path, "params:\n  pose_noise_m: {low: 0.001, high: 0.05}\n")
    spec = TuneSpec(algo="fake_raise", suite=_suite(tmp_path, "dev", draws=1), space=space,
                    trials=2, objective="ate")
    # fake_raise fails under every config, the defaults too: nothing is left to tune on
    with pytest.raises(InputError, match="every row failed under the defaults"):
        tune(spec, tmp_path / "t", jobs=1, progress=False)


def test_the_cli_tunes_graph_on_the_tiny_world_end_to_end(tmp_path, capsys):
    dev = _suite(tmp_path, "dev", draws=1)
    out = tmp_path / "g"
    code = main(["tune", "--algo", "graph", "--suite", dev, "--holdout", dev, "--trials", "3",
                 "--jobs", "1", "--out", str(out), "--no-progress"])
    assert code == 0
    assert "3 complete, 0 pruned, 0 failed trials" in capsys.readouterr().out
    load_config_checked("graph", str(out / "best.yaml"))
    assert "### Hold-out suite" in (out / "summary.md").read_text()


@pytest.mark.parametrize("args, message", [
    (["--algo", "graph,pf", "--suite", "DEV"], "tune one algorithm at a time"),
    (["--algo", "graph", "--suite", "nosuch"], "--suite nosuch: "),
    (["--algo", "graph", "--suite", "DEV", "--holdout", "missing.yaml"], "--holdout missing.yaml: "),
    (["--algo", "graph"], "--algo and --suite are required"),
    (["--algo", "graph", "--suite", "DEV", "--space", "missing.yaml"], "missing.yaml"),
])
def test_cli_errors_are_one_line(tmp_path, capsys, args, message):
    dev = _suite(tmp_path, "dev", draws=1)
    args = [dev if a == "DEV" else a for a in args]
    code = main(["tune", "--out", str(tmp_path / "t")] + args)
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert message in err and len(err.splitlines()) == 1


def test_a_bad_suite_file_names_the_file_and_field(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\ndraws: 0\nworlds: [rectangle_s]\n")
    code = main(["tune", "--algo", "graph", "--suite", str(bad), "--out", str(tmp_path / "t")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and str(bad) in err and "draws" in err and len(err.splitlines()) == 1


def test_resume_refuses_other_arguments(tmp_path, capsys):
    spec = TuneSpec(algo="fake_map", suite=_suite(tmp_path, "dev", draws=1),
                    space=_space(tmp_path, NOISE_SPACE), trials=1, objective="ate")
    tune(spec, tmp_path / "t", jobs=1, progress=False)
    code = main(["tune", "--resume", str(tmp_path / "t"), "--objective", "f1"])
    assert code == 2
    assert "give --trials at most" in capsys.readouterr().err


def _logset(tmp_path: Path, draws: int = 2) -> str:
    """A log set of the tiny world's logs, each with relations between its true poses 1 s apart."""
    import numpy as np
    import sim
    import worlds
    from metrics.relations import Relations, write_relations
    from slam.pose import relative
    entries = []
    for seed in range(draws):
        log = sim.record(worlds.load_world(TINY), seed=seed)
        sim.write_log(log, tmp_path / f"tiny_s{seed}.npz")
        k = np.searchsorted(log.gt_t, log.scan_t[::5])
        t = log.gt_t[np.minimum(k, len(log.gt_t) - 1)]
        p = log.gt_pose[np.minimum(k, len(log.gt_t) - 1)]
        write_relations(tmp_path / f"tiny_s{seed}.relations",
                        Relations(t[:-1], t[1:], relative(p[:-1], p[1:])))
        entries.append(f"  - {{log: tiny_s{seed}.npz, relations: tiny_s{seed}.relations}}")
    path = tmp_path / "logs.yaml"
    path.write_text("name: tinylogs\nlogs:\n" + "\n".join(entries) + "\n")
    return str(path)


def test_a_relations_tune_runs_on_a_log_set_and_holds_out_another(tmp_path):
    logs = _logset(tmp_path)
    spec = TuneSpec(algo="fake_map", suite=logs, holdout=logs, space=_space(tmp_path, NOISE_SPACE),
                    trials=4, objective="relations")
    outcome = tune(spec, tmp_path / "t", jobs=1, progress=False)
    assert outcome.complete == 4
    rows = json.loads((tmp_path / "t" / "trials" / "0000" / "results.json").read_text())["rows"]
    assert sorted(r["world"] for r in rows) == ["tiny_s0", "tiny_s1"]
    assert all(r["relations_abs_trans_m"] > 0 for r in rows)
    assert "mean relation error (m)" in (tmp_path / "t" / "summary.md").read_text()
    # the pose noise is what the relation error measures: the best trial has the least
    best = load_config_checked("fake_map", str(tmp_path / "t" / "best.yaml")).pose_noise_m
    assert best == min(t for t in _trial_values(tmp_path / "t"))


def _trial_values(out: Path) -> list[float]:
    data = json.loads((out / "summary.json").read_text())
    assert data["best_params"]
    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend
    study = optuna.load_study(study_name="tune", storage=JournalStorage(
        JournalFileBackend(str(out / "optuna.journal"))))
    return [t.params["pose_noise_m"] for t in study.trials]


@pytest.mark.parametrize("text, message", [
    ("logs: []\n", "logs: expected a list"),
    ("logs:\n  - {log: nosuch.npz, relations: r.txt}\n", "logs[0].log: nosuch.npz: file not found"),
    ("logs:\n  - {lg: a.npz}\n", "logs[0].lg: unknown key (did you mean 'log'?)"),
    ("name: x\nlog: []\n", "log: unknown key"),
])
def test_a_bad_log_set_names_its_file_and_field(tmp_path, text, message):
    from bench.tune.logset import load_logset
    path = tmp_path / "set.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        load_logset(path)
    assert str(err.value).startswith(f"{path}: ") and message in str(err.value)


def test_a_killed_tune_resumes_to_the_same_best_trial(tmp_path):
    """SIGKILL (a lost machine) part way through a trial; --resume ends as an uninterrupted tune."""
    import os
    import signal
    import subprocess
    import sys
    import time
    repo = Path(__file__).resolve().parents[2]
    space = _space(tmp_path, NOISE_SPACE + "  delay_s: {choices: [0.1]}\n")   # slow runs
    args = ["tune", "--algo", "fake_map", "--suite", _suite(tmp_path, "dev", worlds=2, draws=1),
            "--space", space, "--trials", "6", "--objective", "ate", "--jobs", "1", "--no-progress"]
    code = ("import sys; import tests.bench.fakes; from bench.__main__ import main; "
            "sys.exit(main(sys.argv[1:]))")
    env = dict(os.environ, PYTHONPATH=str(repo))
    killed = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-c", code, *args, "--out", str(killed)], cwd=repo,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    target = killed / "trials" / "0003" / "results.json"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None and not target.exists():
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert target.exists() and not (killed / "summary.md").exists()
    resumed = subprocess.run([sys.executable, "-c", code, "tune", "--resume", str(killed),
                              "--jobs", "1", "--no-progress"],
                             cwd=repo, env=env, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    assert main([*args, "--out", str(tmp_path / "whole")]) == 0
    a = json.loads((killed / "summary.json").read_text())
    b = json.loads((tmp_path / "whole" / "summary.json").read_text())
    assert a == b and a["best_trial"] is not None


def test_a_finished_tune_takes_more_trials_and_judges_its_new_best(tmp_path):
    def spec(trials):
        return TuneSpec(algo="fake_map", suite=_suite(tmp_path, "dev", draws=1),
                        holdout=_suite(tmp_path, "hold", draws=1),
                        space=_space(tmp_path, NOISE_SPACE), trials=trials, objective="ate")
    first = tune(spec(3), tmp_path / "t", jobs=1, progress=False)
    more = tune(spec(8), tmp_path / "t", jobs=1, progress=False, resume=True)
    assert (first.complete, more.complete) == (3, 8)
    assert (tmp_path / "t" / "holdout" / f"trial_{more.best_number:04d}" / "results.json").is_file()
    assert "### Hold-out suite" in (tmp_path / "t" / "summary.md").read_text()


def test_the_comparison_lists_runs_the_tuned_config_failed():
    from bench.tune.objective import get_objective
    from bench.tune.report import compare_runs
    ate = get_objective("ate")
    base = [{"world": w, "draw": d, "status": "ok", "ate_m": 0.02} for w in "ab" for d in (0, 1)]
    other = [dict(r, ate_m=0.01) for r in base[:3]] + [dict(base[3], status="failed",
                                                              error="diverged", ate_m=None)]
    cmp = compare_runs(ate, base, other, {})
    assert cmp["failed"] == ["b draw 1: diverged"]
    assert cmp["diff_mean"] == pytest.approx(-0.01) and cmp["better_worlds"] == 2
