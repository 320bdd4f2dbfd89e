"""`bench tune`: Optuna searches an algorithm's config on a dev suite; the best config is then
run beside the defaults on a hold-out suite.

A trial is a bench run of one algorithm over the dev suite with the trial's values set on top
of the defaults (DIR/trials/NNNN, a run folder like any); with objective relations, a run over
a log set's logs, each scored with its relations (bench.tune.logset). The sampler is Optuna's TPE, seeded
per trial from the tune's seed and the trial's number, so a tune is a function of its
arguments. The median pruner sees, after each world of the suite's order is done, the mean
over the worlds so far, and stops a trial whose mean is worse than the median of the earlier
trials' at the same world. The study lives in DIR/optuna.journal: an interrupted tune resumes
(`--resume DIR`) with the trial it was running (the same values, its finished rows kept) and
goes on to the same trials an uninterrupted tune runs.

Rows that fail under the default config (a log that cannot be trusted, a world where the
defaults fail) are left out of every trial alike and listed in the report; a trial with any
other failed row fails, with the reason, and is never the best.

DIR/tune.json        the tune's arguments
DIR/optuna.journal   the Optuna study (JournalStorage)
DIR/defaults/        the dev suite with the default config
DIR/trials/NNNN/     trial NNNN's bench run
DIR/best.yaml        the best trial's values, a config file for --config
DIR/holdout/defaults/, DIR/holdout/trial_NNNN/   the hold-out suite with the defaults and
                     with the best trial's values (a tune given more trials may find another)
DIR/summary.md, DIR/figures/   the report (bench.tune.report)
"""
from __future__ import annotations

import dataclasses
import json
import sys
from dataclasses import dataclass
from pathlib import Path

from worlds.yamlio import InputError, atomic_write_text, dump_yaml, short
from bench.tune.objective import OBJECTIVES, excluded_rows, get_objective, world_prefix_values
from bench.tune.space import SearchSpace, load_space, overrides_of

__all__ = ["TuneSpec", "TuneOutcome", "tune", "read_tune", "TUNE_NAME", "MAX_TRIALS"]

TUNE_NAME = "tune.json"
JOURNAL_NAME = "optuna.journal"
BEST_NAME = "best.yaml"
STUDY_NAME = "tune"
MAX_TRIALS = 10_000
# TPE draws its first trials at random (Optuna's default count), then models the rest
STARTUP_TRIALS = 10
# the pruner waits for this many finished trials, and for this share of the suite's worlds
PRUNER_STARTUP_TRIALS = 5
PRUNER_WARMUP_SHARE = 0.25


@dataclass(frozen=True)
class TuneSpec:
    """The arguments that decide a tune: the algorithm, the dev suite and the hold-out suite
    (names or absolute paths; holdout "" = none), the space file ("" = the shipped space),
    the number of trials, the objective (f1, ate, or relations: then the suites are log sets,
    bench.tune.logset) and the sampler's seed."""

    algo: str
    suite: str
    holdout: str = ""
    space: str = ""
    trials: int = 40
    objective: str = "f1"
    seed: int = 0

    def __post_init__(self):
        if self.objective not in OBJECTIVES:
            raise InputError(f"--objective: expected one of {', '.join(OBJECTIVES)}, got "
                             f"{short(self.objective)}")
        t = self.trials
        if isinstance(t, bool) or not isinstance(t, int) or not 1 <= t <= MAX_TRIALS:
            raise InputError(f"--trials must be an integer from 1 to {MAX_TRIALS:,}, got {short(t)}")


@dataclass
class TuneOutcome:
    """How a tune ended: its folder, trials finished (complete, pruned, failed), the best
    trial's number and value (None: no complete trial), interrupted or not."""

    out_dir: Path
    complete: int = 0
    pruned: int = 0
    failed: int = 0
    best_number: int | None = None
    best_value: float | None = None
    interrupted: bool = False


def read_tune(out_dir: Path) -> TuneSpec:
    """The TuneSpec of the tune in `out_dir` (its tune.json)."""
    path = out_dir / TUNE_NAME
    try:
        data = json.loads(path.read_text())
        return TuneSpec(**data["spec"])
    except FileNotFoundError:
        raise InputError(f"--resume {out_dir}: no {TUNE_NAME} there: nothing to resume") from None
    except (ValueError, KeyError, TypeError) as err:
        raise InputError(f"{path}: spec: not a tune's arguments ({err})") from None


class _SuiteTarget:
    """What a trial runs with objective f1 or ate: a bench run of the suite."""

    def __init__(self, algo: str, suite: str):
        from bench.spec import spec_from_options
        self.algo = algo
        self.spec = spec_from_options(suite=suite, algo=algo)

    def order(self) -> tuple[list[str], dict[str, int]]:
        """The world keys in task order, and how many rows each has."""
        from bench.plan import make_tasks
        from bench.runner import cross_lidars, load_worlds
        keys = list(cross_lidars(*load_worlds(list(self.spec.worlds)), self.spec.lidars)[0])
        order: list[str] = []
        n: dict[str, int] = {}
        for task in make_tasks(self.spec, keys):
            if task.world not in n:
                order.append(task.world)
            n[task.world] = n.get(task.world, 0) + 1
        return order, n

    def run(self, values: dict, folder: Path, jobs, scheduler, on_row) -> str:
        """Run (or complete) the suite with `values` into `folder`: "complete", "stopped",
        "interrupted" or the reason a worker crashed."""
        from bench.results import RUN_NAME
        from bench.runner import run_benchmark
        spec = dataclasses.replace(self.spec, overrides={self.algo: overrides_of(values)}
                                   if values else {})
        outcome = run_benchmark(spec, folder, jobs=jobs, scheduler=scheduler,
                                resume=(folder / RUN_NAME).exists(), progress=False,
                                on_row=on_row)
        if outcome.crashed:
            return outcome.crashed
        return ("interrupted" if outcome.interrupted else
                "stopped" if outcome.stopped else "complete")


class _LogSetTarget:
    """What a trial runs with objective relations: the logs of a log set."""

    def __init__(self, algo: str, path: str):
        from bench.tune.logset import load_logset
        self.algo = algo
        self.logset = load_logset(path)

    def order(self) -> tuple[list[str], dict[str, int]]:
        names = [e.name for e in self.logset.logs]
        return names, {n: 1 for n in names}

    def run(self, values: dict, folder: Path, jobs, scheduler, on_row) -> str:
        from bench.tune.logset import run_logset
        return run_logset(self.algo, self.logset, overrides_of(values), folder, jobs, scheduler,
                          on_row)


def make_target(algo: str, objective: str, suite: str):
    """The runs a trial makes: a log set for objective relations, else a suite."""
    if objective == "relations":
        return _LogSetTarget(algo, suite)
    return _SuiteTarget(algo, suite)


def tune(spec: TuneSpec, out_dir: str | Path, jobs: int | None = None,
         scheduler: str | None = None, resume: bool = False, progress: bool = True,
         stream=None) -> TuneOutcome:
    """Run (or, with resume=True, go on with) the tune `spec` in `out_dir`; see the module
    docstring. InputError on bad arguments, before any trial runs."""
    from bench.rundir import run_lock
    out_dir = Path(out_dir)
    stream = stream or sys.stderr
    space = load_space(spec.space or None, spec.algo)
    dev = make_target(spec.algo, spec.objective, spec.suite)
    hold = make_target(spec.algo, spec.objective, spec.holdout) if spec.holdout else None
    _check_folder(out_dir, spec, resume)
    with run_lock(out_dir):
        atomic_write_text(out_dir / TUNE_NAME,
                          json.dumps({"spec": dataclasses.asdict(spec)}, indent=1) + "\n")
        return _Tuner(spec, space, dev, hold, out_dir, jobs, scheduler, progress, stream).run()


def _check_folder(out_dir: Path, spec: TuneSpec, resume: bool) -> None:
    if resume:
        before = read_tune(out_dir)
        if dataclasses.replace(before, trials=spec.trials) != spec:
            raise InputError(f"--resume {out_dir}: the tune was started with other arguments; "
                             "resume it with --trials at most")
    elif out_dir.exists() and any(out_dir.iterdir()):
        raise InputError(f"{out_dir} is not empty; use --resume {out_dir} to go on with a tune, "
                         "or choose another --out")


class _Tuner:
    """One tune's state while it runs: the study, the excluded rows, the dev suite's order."""

    def __init__(self, spec: TuneSpec, space: SearchSpace, dev, hold, out_dir: Path, jobs,
                 scheduler, progress: bool, stream):
        self.spec, self.space, self.dev, self.hold = spec, space, dev, hold
        self.out_dir, self.jobs, self.scheduler = out_dir, jobs, scheduler
        self.progress, self.stream = progress, stream
        self.objective = get_objective(spec.objective)
        self.outcome = TuneOutcome(out_dir)

    def say(self, text: str) -> None:
        if self.progress:
            print(text, file=self.stream, flush=True)

    def run(self) -> TuneOutcome:
        import optuna
        optuna.logging.set_verbosity(optuna.logging.WARNING)
        defaults = self.bench(self.dev, {}, self.out_dir / "defaults", "the dev suite, defaults")
        if defaults is None:
            self.outcome.interrupted = True
            return self.outcome
        self.excluded = excluded_rows(defaults)
        if len(self.excluded) >= len({(r["world"], r.get("draw")) for r in defaults}):
            raise InputError(f"{self.out_dir / 'defaults'}: every row failed under the defaults; "
                             "nothing to tune on")
        self.order, self.n_rows = self.dev.order()
        storage = self.storage()
        while True:
            study = self.study(storage, len(optuna.load_study(study_name=STUDY_NAME,
                                                              storage=storage).trials))
            finished = [t for t in study.trials if t.state.is_finished()]
            if len(finished) >= self.spec.trials:
                break
            if not self.run_trial(study):
                self.outcome.interrupted = True
                return self._count(study)
        self._count(study)
        best = self.write_best(study)
        if best is not None and self.hold is not None:
            number = study.best_trial.number
            for name, values in (("defaults", {}), (f"trial_{number:04d}", best)):
                if self.bench(self.hold, values, self.out_dir / "holdout" / name,
                              f"the hold-out suite, {name}") is None:
                    self.outcome.interrupted = True
                    return self.outcome
        from bench.tune.report import write_tune_report
        md = write_tune_report(self.out_dir)
        self.say(f"report: {md}")
        return self.outcome

    def storage(self):
        import optuna
        from optuna.storages import JournalStorage
        from optuna.storages.journal import JournalFileBackend
        storage = JournalStorage(JournalFileBackend(str(self.out_dir / JOURNAL_NAME)))
        study = optuna.create_study(study_name=STUDY_NAME, storage=storage, load_if_exists=True,
                                    direction=self.objective.direction)
        if not study.trials:
            start = self.space.defaults()
            if start is not None:
                # the first trial is the defaults (when the space holds them): TPE then has a
                # good point to search around, and the pruner a fair median from the start
                study.enqueue_trial(start, user_attrs={"defaults": True})
        return storage

    def study(self, storage, number: int):
        """The study with a sampler seeded for trial `number` (TPE is deterministic given the
        trials before it and its seed, so a resumed tune draws what an uninterrupted one does)."""
        import optuna
        sampler = optuna.samplers.TPESampler(seed=self.spec.seed * 1_000_003 + number,
                                             n_startup_trials=STARTUP_TRIALS)
        pruner = optuna.pruners.MedianPruner(
            n_startup_trials=PRUNER_STARTUP_TRIALS,
            n_warmup_steps=max(1, int(PRUNER_WARMUP_SHARE * len(self.order))))
        return optuna.load_study(study_name=STUDY_NAME, storage=storage, sampler=sampler,
                                 pruner=pruner)

    def run_trial(self, study) -> bool:
        """Run the next trial (or finish the one an interrupt left running); False when this
        one was interrupted."""
        import optuna
        from optuna.trial import TrialState
        running = [t for t in study.trials if t.state == TrialState.RUNNING]
        # Optuna has no public call that re-opens a running trial; a Trial on its id returns
        # the values it already drew
        trial = (optuna.Trial(study, running[0]._trial_id) if running else study.ask())
        values = self.space.suggest(trial)
        folder = self.out_dir / "trials" / f"{trial.number:04d}"
        trial.set_user_attr("run", str(folder.relative_to(self.out_dir)))
        state = _TrialRows(self, trial, folder)
        rows = self.bench(self.dev, values, folder, None, on_row=state.on_row,
                          seed_rows=state.seed)
        if rows is None and not state.stopped:
            return False
        if state.failure:
            trial.set_user_attr("failure", state.failure)
            study.tell(trial, state=TrialState.FAIL)
            note = f"failed: {state.failure[:80]}"
        elif state.pruned:
            study.tell(trial, state=TrialState.PRUNED)
            note = f"pruned after {state.reported} of {len(self.order)} worlds"
        else:
            value = state.values[-1]
            study.tell(trial, value)
            note = f"{value:.5g}"
        try:
            best = f"best {study.best_value:.5g} (trial {study.best_trial.number})"
        except ValueError:
            best = "no complete trial yet"
        self.say(f"trial {trial.number + 1}/{self.spec.trials}: {note}; {best}")
        return True

    def bench(self, target, values: dict, folder: Path, what: str | None, on_row=None,
              seed_rows=None):
        """Run (or complete) `target` with `values` into `folder`; its rows, or None when
        interrupted or stopped."""
        from bench.results import RESULTS_NAME, ResultStore
        started = (folder / RESULTS_NAME).exists()
        if seed_rows is not None and started:
            if seed_rows(list(ResultStore(folder).rows.values())):
                return None
        if what:
            self.say(f"{'completing' if started else 'running'} {what} in {folder}")
        end = target.run(values, folder, self.jobs, self.scheduler, on_row)
        if end != "complete":
            if end not in ("stopped", "interrupted"):
                self.say(f"{folder}: {end}")
            return None
        return list(ResultStore(folder).rows.values())

    def write_best(self, study) -> dict | None:
        """DIR/best.yaml from the best complete trial; its values, or None without one."""
        try:
            best = study.best_trial
        except ValueError:
            self.say("no trial completed: no best config")
            return None
        values = {p.path: best.params[p.path] for p in self.space.params}
        head = (f"# bench tune: {self.spec.algo}, best of {self.spec.trials} trials on "
                f"{self.spec.suite} (trial {best.number}, {self.objective.label} "
                f"{best.value:.5g}); python -m slam run --config this file\n")
        atomic_write_text(self.out_dir / BEST_NAME, head + dump_yaml(overrides_of(values)))
        return values

    def _count(self, study) -> TuneOutcome:
        from optuna.trial import TrialState
        o = self.outcome
        o.complete = sum(t.state == TrialState.COMPLETE for t in study.trials)
        o.pruned = sum(t.state == TrialState.PRUNED for t in study.trials)
        o.failed = sum(t.state == TrialState.FAIL for t in study.trials)
        try:
            o.best_number, o.best_value = study.best_trial.number, study.best_value
        except ValueError:
            pass
        return o


class _TrialRows:
    """A trial's rows as they arrive: the pruner is shown each finished world, a failure not
    seen under the defaults ends the trial."""

    def __init__(self, tuner: _Tuner, trial, folder: Path):
        self.tuner, self.trial = tuner, trial
        self.rows: list[dict] = []
        self.values: list[float] = []
        self.reported = len(trial.storage.get_trial(trial._trial_id).intermediate_values)
        self.failure: str | None = None
        self.pruned = False

    @property
    def stopped(self) -> bool:
        return self.pruned or self.failure is not None

    def seed(self, rows: list[dict]) -> bool:
        """The rows a resumed trial already has; True when they end it."""
        for row in rows:
            if self.on_row(row):
                return True
        return False

    def on_row(self, row: dict) -> bool:
        t = self.tuner
        self.rows.append(row)
        key = (row["world"], int(row.get("draw") or 0))
        if row.get("status") != "ok" and key not in t.excluded:
            self.failure = f"{row['world']} draw {key[1]}: {row.get('error') or 'failed'}"
            return True
        self.values = world_prefix_values(t.objective, self.rows, t.order, t.n_rows, t.excluded)
        while self.reported < len(self.values):
            self.trial.report(self.values[self.reported], step=self.reported)
            self.reported += 1
            if self.reported < len(t.order) and self.trial.should_prune():
                self.pruned = True
                return True
        return False
