"""python -m bench run | tune | add | merge | report | regress | speed  (a thin CLI over bench's
Python API)."""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from worlds.cli import Parser, check_out_dir, non_negative_int, positive_int, run_cli, share_0_1
from worlds.yamlio import InputError


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="python -m bench", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)

    _add_run_command(sub)
    _add_tune_command(sub)

    m = sub.add_parser("merge", help="join the shards of one run (bench run --shard K/N) into one run")
    m.add_argument("dirs", nargs="+", metavar="DIR", help="shard folders")
    m.add_argument("--out", required=True, help="the merged run's folder (new)")
    m.add_argument("--no-figures", action="store_true", help="tables only")

    sp = sub.add_parser("speed", help="real-time factors of the simulator and each algorithm on "
                                      "the shipped worlds (median of --runs, one core)")
    sp.add_argument("--world", default="all", help="world names or 'all' (default)")
    sp.add_argument("--algo", help="comma-separated algorithms (default: the shipped ones)")
    sp.add_argument("--runs", type=positive_int, default=3, help="runs per figure (default 3)")
    sp.add_argument("--noise", default="realistic", help="sensor-noise profile (default realistic)")

    rep = sub.add_parser("report", help="rebuild summary.md/.csv and figures from results.json")
    rep.add_argument("dir")
    rep.add_argument("--no-figures", action="store_true")
    rep.add_argument("--update", action="append", metavar="PAGE",
                     help="refill the tables of PAGE marked as this run's (repeatable; run from "
                          "the repository's root: the summary is kept as docs/runs/NAME.md)")
    rep.add_argument("--run-name", help="NAME in the pages' markers (default: DIR's folder name)")

    _add_add_command(sub)

    g = sub.add_parser("regress", help="rerun a small fixed matrix and compare with a baseline")
    g.add_argument("--baseline", help="baseline JSON (default: bench/baseline.json)")
    g.add_argument("--update", action="store_true", help="write the baseline instead")
    g.add_argument("--world", help="worlds of the matrix (default: the baseline's)")
    g.add_argument("--algo", help="algorithms of the matrix (default: the baseline's)")
    g.add_argument("--repeats", type=positive_int, help="repeats (default: the baseline's)")
    g.add_argument("--jobs", type=positive_int, default=None, help="worker processes (default: all cores)")
    g.add_argument("--out", help="keep the regression run in this directory")
    return p


def _add_run_command(sub) -> None:
    r = sub.add_parser("run", help="run worlds x algorithms x repeats, write results and report")
    r.add_argument("--world", help="world name(s) or YAML file(s), comma-separated, or 'all'")
    r.add_argument("--logs", metavar="DIR|FILE,...",
                   help="run on these recorded sensor logs (a folder of .npz or files) instead of "
                        "recording; each log's world gives its true map")
    r.add_argument("--suite", metavar="NAME|FILE",
                   help="a suite of worlds (shipped: general) or a suite YAML file; each world is "
                        "recorded with --draws noise draws")
    r.add_argument("--draws", type=positive_int,
                   help="noise draws per world (default: the suite's, 3; 1 without a suite)")
    r.add_argument("--min-coverage", type=share_0_1, metavar="SHARE",
                   help="a log whose lidar saw less than this share of the true wall cells gives "
                        "failed rows (default 0.95)")
    r.add_argument("--repeats", type=positive_int,
                   help="runs per world, algorithm and draw (default 10; 1 with --suite)")
    r.add_argument("--algo", help="comma-separated algorithms (default: all registered)")
    r.add_argument("--noise", help="sensor-noise profile name or YAML (default realistic)")
    r.add_argument("--lidar", metavar="NAME|FILE,...",
                   help="record with these lidars (python -m sim lidars), each world crossed with "
                        "each (default: the suite's, else the LDS-01)")
    r.add_argument("--seed", type=non_negative_int, help="base seed, a non-negative integer (default 0)")
    r.add_argument("--vary", choices=["slam", "data", "both"],
                   help="what changes between repeats: SLAM seed (default, as the study), "
                        "sensor-noise seed, or both")
    r.add_argument("--config", action="append", metavar="ALGO=YAML",
                   help="config file of one algorithm (repeatable)")
    r.add_argument("--set", action="append", metavar="ALGO.FIELD=VALUE",
                   help="set one config field of one algorithm, on top of --config "
                        "(repeatable; e.g. pf.particles=50, graph.pose_graph.enable_loop_closure=false)")
    r.add_argument("--jobs", type=positive_int, default=None, help="worker processes (default: all cores)")
    r.add_argument("--out", help="output directory (default runs/<UTC timestamp>)")
    r.add_argument("--resume", metavar="DIR", help="complete the run in DIR (same seeds)")
    r.add_argument("--shard", metavar="K/N", type=parse_shard_flag,
                   help="run only the K-th of N deterministic slices of the tasks (e.g. one task "
                        "of a SLURM job array); join the shards with `bench merge`")
    r.add_argument("--scheduler", metavar="ADDRESS",
                   help="Dask scheduler address (tcp://host:8786, or 'local'); needs .[dask]")
    r.add_argument("--no-progress", action="store_true", help="no progress output")
    r.add_argument("--no-figures", action="store_true", help="tables only")


def _add_tune_command(sub) -> None:
    t = sub.add_parser("tune", help="search an algorithm's config with Optuna on a dev suite, "
                                    "then run the best beside the defaults on a hold-out suite")
    t.add_argument("--algo", help="the algorithm to tune (one)")
    t.add_argument("--suite", metavar="DEV", help="the dev suite (a shipped name or a suite YAML; "
                                                  "with --objective relations a log set YAML) "
                                                  "the trials run on")
    t.add_argument("--holdout", metavar="HOLD", help="a suite not looked at while choosing: the "
                                                     "best config and the defaults both run on it")
    t.add_argument("--space", metavar="SPACE.yaml",
                   help="the search space (default: the algorithm's shipped space)")
    t.add_argument("--trials", type=positive_int, help="trials (default 40)")
    t.add_argument("--objective", choices=["f1", "ate", "relations"],
                   help="mean map F1 (surface form; default) or mean ATE over the suite's runs, "
                        "or the mean relation error over a log set's logs")
    t.add_argument("--seed", type=non_negative_int, help="the sampler's seed (default 0)")
    t.add_argument("--jobs", type=positive_int, default=None,
                   help="worker processes a trial's runs share (default: all cores)")
    t.add_argument("--scheduler", metavar="ADDRESS",
                   help="Dask scheduler address for the trials' runs; needs .[dask]")
    t.add_argument("--out", help="the tune's folder (default runs/tune-<UTC timestamp>)")
    t.add_argument("--resume", metavar="DIR", help="go on with the tune in DIR (--trials may "
                                                   "raise its count)")
    t.add_argument("--no-progress", action="store_true", help="no progress output")


def _add_add_command(sub) -> None:
    a = sub.add_parser("add", help="score a map (and trajectory) made elsewhere, e.g. by a ROS "
                                   "SLAM, into a run's results and report")
    a.add_argument("dir", metavar="RUN_DIR", help="a bench run folder (run.json, results.json)")
    a.add_argument("--world", required=True, metavar="W", help="one of the run's worlds, as its rows name it")
    a.add_argument("--algo", required=True, metavar="NAME",
                   help="the outside algorithm's name, not one of the run's (e.g. slam_toolbox)")
    a.add_argument("--map", metavar="MAP.yaml",
                   help="its map: a map_server YAML with a PGM or PNG image (or --render)")
    a.add_argument("--trajectory", metavar="T.tum",
                   help="its TUM trajectory, scored against the true path of the draw's log")
    a.add_argument("--render", action="store_true",
                   help="instead of --map: build the map from --trajectory and the draw's log "
                        "with this project's output map")
    a.add_argument("--draw", type=non_negative_int, default=0, metavar="K",
                   help="the noise draw whose log it ran on (default 0)")
    a.add_argument("--no-figures", action="store_true", help="rebuild the tables only")


def cmd_run(args, argv) -> int:
    from bench.cache import cache_dir
    from bench.report import write_report
    from bench.rundir import check_run_dir, default_out_dir
    from bench.runner import print_outcome, run_benchmark
    from bench.spec import spec_from_options
    if args.resume and args.out and Path(args.out) != Path(args.resume):
        raise InputError("give either --resume DIR or --out DIR, not both")
    out_dir = check_out_dir(args.resume or args.out or default_out_dir(),
                            "--resume" if args.resume else "--out")
    check_run_dir(out_dir, bool(args.resume))   # before a suite's worlds are generated
    spec = spec_from_options(
        world=args.world, suite=args.suite, logs=args.logs, algo=args.algo, repeats=args.repeats,
        draws=args.draws, seed=args.seed, noise=args.noise, vary=args.vary,
        min_coverage=args.min_coverage, configs=args.config, sets=args.set, shard=args.shard,
        resume=args.resume, lidar=args.lidar)
    if not spec.logs:
        cache_dir()  # the logs are recorded into it: a cache that cannot be made fails now
    outcome = run_benchmark(spec, out_dir, jobs=args.jobs, scheduler=args.scheduler,
                            resume=bool(args.resume), progress=not args.no_progress, argv=argv)
    print_outcome(outcome)
    if outcome.interrupted:
        return 130
    if outcome.crashed:
        return 1
    md = write_report(out_dir, figures=not args.no_figures)
    print(f"report: {md}")
    return 0


def cmd_tune(args) -> int:
    from bench.rundir import default_out_dir
    from bench.tune import TuneSpec, read_tune, tune
    if args.resume and args.out and Path(args.out) != Path(args.resume):
        raise InputError("give either --resume DIR or --out DIR, not both")
    if args.resume:
        out_dir = check_out_dir(args.resume, "--resume")
        base = read_tune(out_dir)
        given = {"algo": args.algo, "suite": args.suite, "holdout": args.holdout,
                 "space": args.space, "objective": args.objective, "seed": args.seed}
        if any(v is not None for v in given.values()):
            raise InputError("--resume takes the tune's arguments from its tune.json; give "
                             "--trials at most")
        spec = dataclasses.replace(base, trials=args.trials or base.trials)
    else:
        if not args.algo or not args.suite:
            raise InputError("tune: --algo and --suite are required")
        from bench.plan import resolve_algos
        algos = resolve_algos(args.algo)
        if len(algos) != 1:
            raise InputError(f"--algo {args.algo}: tune one algorithm at a time")
        stamp = default_out_dir()
        out_dir = check_out_dir(args.out or stamp.with_name("tune-" + stamp.name))
        logs = args.objective == "relations"
        spec = TuneSpec(algo=algos[0], suite=_suite_ref(args.suite, "--suite", logs),
                        holdout=_suite_ref(args.holdout, "--holdout", logs) if args.holdout else "",
                        space=str(Path(args.space).resolve()) if args.space else "",
                        trials=args.trials or 40, objective=args.objective or "f1",
                        seed=args.seed or 0)
    outcome = tune(spec, out_dir, jobs=args.jobs, scheduler=args.scheduler,
                   resume=bool(args.resume), progress=not args.no_progress)
    head = (f"{outcome.complete} complete, {outcome.pruned} pruned, {outcome.failed} failed "
            f"trials in {out_dir}")
    if outcome.interrupted:
        print(f"interrupted: {head}; go on with: python -m bench tune --resume {out_dir}",
              file=sys.stderr)
        return 130
    best = ("no complete trial" if outcome.best_number is None else
            f"best: trial {outcome.best_number}, {outcome.best_value:.5g} ({out_dir / 'best.yaml'})")
    print(f"{head}; {best}")
    return 0


def _suite_ref(text: str, flag: str, logs: bool = False) -> str:
    """A suite argument as the tune keeps it: a shipped name, or the file's absolute path;
    InputError naming the flag when it does not load. logs: it is a log set (objective
    relations)."""
    from bench.suite import load_suite
    from bench.tune.logset import load_logset
    from worlds.paths import names_a_file
    try:
        if logs:
            return load_logset(text).source
        load_suite(text)
    except InputError as err:
        msg = str(err)
        raise InputError(msg if msg.startswith(flag) else f"{flag} {text}: {msg}") from None
    return str(Path(text).resolve()) if names_a_file(text) else text


def cmd_report(args) -> int:
    from bench.report import write_report
    md = write_report(args.dir, figures=not args.no_figures)
    print(f"report: {md}")
    if args.update:
        from bench.doctables import update_docs
        name = args.run_name or Path(args.dir).resolve().name
        for line in update_docs(Path(md), args.update, name, Path.cwd()):
            print(line)
    return 0


def cmd_add(args) -> int:
    from bench.add import add_outside
    row = add_outside(args.dir, args.world, args.algo, args.map, args.trajectory, args.draw,
                      figures=not args.no_figures, render=args.render)
    def num(key):
        return "–" if row.get(key) is None else f"{row[key]:.3f}"
    traj = f", ATE {num('ate_m')} m" if args.trajectory else ""
    cell = "study's cell rule"
    if row.get("surface_precision") is not None:
        main = (f"precision {num('surface_precision')}, sensitivity "
                f"{num('surface_sensitivity')} (surface, tau = {row['surface_tau_m']:g} m); "
                f"{cell}: {num('precision')} / {num('sensitivity')}")
    else:
        main = f"precision {num('precision')}, sensitivity {num('sensitivity')} ({cell})"
    print(f"{row['world']}/{row['algo']}/{row['repeat']}: {main}{traj}")
    print(f"report: {Path(args.dir) / 'summary.md'}")
    return 0


def cmd_regress(args) -> int:
    from bench.plan import parse_worlds, resolve_algos
    from bench.regress import regress
    return regress(args.baseline, update=args.update,
                   worlds=parse_worlds(args.world) if args.world is not None else None,
                   algos=resolve_algos(args.algo) if args.algo is not None else None,
                   repeats=args.repeats, jobs=args.jobs, out=args.out)


def cmd_merge(args) -> int:
    from bench.merge import merge_runs
    from bench.report import write_report
    n, missing = merge_runs(args.dirs, args.out)
    note = (f"; shards {', '.join(map(str, missing))} missing: complete them with "
            f"python -m bench run --resume {args.out}") if missing else ""
    print(f"{n} rows from {len(args.dirs)} shards in {args.out}{note}")
    print(f"report: {write_report(args.out, figures=not args.no_figures)}")
    return 0


def cmd_speed(args) -> int:
    from bench.plan import parse_worlds, resolve_algos, shipped_algos
    from bench.speed import speed_table
    algos = resolve_algos(args.algo) if args.algo else shipped_algos()
    table = speed_table(parse_worlds(args.world), algos, args.runs, args.noise, stream=sys.stderr)
    print(table)
    return 0


def parse_shard_flag(text: str):
    from bench.plan import parse_shard
    return parse_shard(text)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    commands = {"run": lambda args: cmd_run(args, argv), "tune": cmd_tune, "report": cmd_report,
                "add": cmd_add,
                "regress": cmd_regress, "merge": cmd_merge, "speed": cmd_speed}
    return run_cli(build_parser, lambda args: commands[args.command](args), argv)


if __name__ == "__main__":
    sys.exit(main())
