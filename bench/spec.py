"""From what a user asks of `bench run` to the RunSpec it runs (the CLI only parses).

One of `world` (names, YAML files or 'all'), `suite` (a shipped name or a suite YAML) and
`logs` (recorded sensor logs) says what to run on; `resume` (a run folder) takes its run.json's
spec, with any option given changing it (then run_benchmark refuses to resume a run started
with other arguments). Options left None take their defaults: 10 repeats (1 per draw of a
suite), noise "realistic" ("recorded" for logs), seed 0, vary "slam", every registered
algorithm, min_coverage 0.95, the whole run (shard 1/1).
"""
from __future__ import annotations

from pathlib import Path

from worlds.yamlio import InputError
from bench.plan import RunSpec, parse_configs, parse_overrides, parse_worlds, read_log_set, resolve_algos
from bench.results import RUN_NAME, read_run, run_spec

__all__ = ["spec_from_options"]


def spec_from_options(*, world: str | None = None, suite: str | None = None,
                      logs: str | None = None, algo: str | None = None, repeats: int | None = None,
                      draws: int | None = None, seed: int | None = None, noise: str | None = None,
                      vary: str | None = None, min_coverage: float | None = None,
                      configs: list[str] | None = None, sets: list[str] | None = None,
                      shard: tuple[int, int] | None = None, resume: str | Path | None = None,
                      lidar: str | None = None) -> RunSpec:
    """The RunSpec of these `bench run` options (each as its flag takes it: algo "pf,gn",
    configs ["pf=pf.yaml"], sets ["pf.particles=50"], shard (K, N), lidar "utm-30lx,lds-01");
    see the module docstring.
    InputError when they do not fit together or name something that is not there."""
    if sum(bool(v) for v in (world, suite, logs)) > 1:
        raise InputError("give one of --world, --suite and --logs")
    base = None
    if resume:
        base = run_spec(read_run(Path(resume)), Path(resume) / RUN_NAME)
        given = (world, suite, logs, draws, min_coverage, algo, repeats, seed, noise, vary, shard,
                 lidar)
        if all(v is None for v in given) and not configs and not sets:
            return base
    elif not (world or suite or logs):
        raise InputError("run: --world, --suite or --logs is required (a world name, a YAML "
                         "file, a list or 'all'; a suite such as 'general'; a folder of logs)")
    loaded_suite = None
    if suite:
        from bench.suite import load_suite
        loaded_suite = load_suite(suite)
    algos = resolve_algos(algo) if algo is not None or base is None else list(base.algos)
    worlds, suite_name, dflt_draws, dflt_repeats, log_files, dflt_noise = _what_to_run(
        world, loaded_suite, logs, base)
    return RunSpec(
        worlds=worlds,
        algos=tuple(algos),
        repeats=repeats if repeats is not None else dflt_repeats,
        noise=noise or dflt_noise or (base.noise if base else "realistic"),
        seed=seed if seed is not None else (base.seed if base else 0),
        vary=vary or (base.vary if base else "slam"),
        configs=parse_configs(configs, algos) if configs else (base.configs if base else {}),
        draws=draws if draws is not None else dflt_draws,
        min_coverage=min_coverage if min_coverage is not None else
        (base.min_coverage if base else 0.95),
        suite=suite_name,
        logs=log_files,
        overrides=parse_overrides(sets, algos) if sets else (base.overrides if base else {}),
        shard=shard or (base.shard if base else (1, 1)),
        lidars=(tuple(v.strip() for v in lidar.split(",") if v.strip()) if lidar else
                loaded_suite.lidars if loaded_suite is not None else (base.lidars if base else ())),
    )


def _what_to_run(world, suite, logs, base: RunSpec | None):
    """(worlds, suite name, draws, repeats, log files, noise) of the one of world, suite (loaded)
    and logs given, else of the resumed run's spec `base`; draws, repeats and noise are the
    defaults the options override (noise None: the resumed run's or the default profile)."""
    resumed_noise = base.noise if base else None
    if suite is not None:
        return suite.worlds, suite.name, suite.draws, 1, (), resumed_noise
    if logs:
        found = read_log_set(logs)
        noise = ",".join(sorted({n for *_, n in found if n})) or "recorded"
        return (tuple(dict.fromkeys(w for _, w, _, _ in found)), "", 1, 10,
                tuple(path for path, *_ in found), noise)
    if world:
        return tuple(parse_worlds(world)), "", 1, 10, (), resumed_noise
    return base.worlds, base.suite, base.draws, base.repeats, base.logs, base.noise
