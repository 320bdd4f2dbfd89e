"""The benchmark: worlds x algorithms x repeats -> results.json, summary tables, figures.

Python API (each is what a `python -m bench` command calls):
  spec_from_options(world=..., algo=..., repeats=..., ...) -> RunSpec (bench.spec: the flags
    of `bench run` as keywords)
  run_benchmark(RunSpec(...), out_dir, jobs=None, scheduler=None, resume=False) -> RunOutcome
  write_report(out_dir) -> Path of summary.md
  add_outside(out_dir, world, algo, map_yaml, trajectory=None, draw=0) -> row (bench.add)
  regress(baseline=None, update=False, ...) -> exit code
  bench.tune.tune(TuneSpec(algo=..., suite=..., holdout=...), out_dir, ...) -> TuneOutcome
    (`bench tune`: a config searched with Optuna on a dev suite, judged on a hold-out suite)
"""
from bench.plan import RunSpec, Task
from bench.regress import regress
from bench.report import write_report
from bench.results import comparable, read_rows
from bench.runner import RunOutcome, run_benchmark

__all__ = ["RunSpec", "Task", "run_benchmark", "RunOutcome", "write_report", "regress",
           "read_rows", "comparable"]
