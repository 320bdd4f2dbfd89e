"""`bench tune`: an algorithm's config searched with Optuna on a dev suite, the best config
judged beside the defaults on a hold-out suite.

  tune(TuneSpec(algo=, suite=, holdout=, space=, trials=, objective=, seed=), out_dir, ...)
  load_space(path or None, algo) -> SearchSpace (None: the shipped bench/tune/spaces/ALGO.yaml)
  write_tune_report(out_dir) -> Path of summary.md
"""
from bench.tune.report import write_tune_report
from bench.tune.search import TuneOutcome, TuneSpec, read_tune, tune
from bench.tune.space import SearchSpace, load_space

__all__ = ["tune", "TuneSpec", "TuneOutcome", "read_tune", "load_space", "SearchSpace",
           "write_tune_report"]
