"""Command line: `python -m slam run --algo NAME --log LOG --out DIR [--config YAML] [--seed S]`
(`--explain` instead of `--out`: print the values the algorithm derives from the log),
`python -m slam list`, `python -m slam fields NAME [--update PAGE]`. User errors print one line `error: ...` and exit with code 2."""
from __future__ import annotations

import argparse
import sys

from worlds.cli import Parser, check_out_dir, non_negative_int, run_cli


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="python -m slam", description="Run a 2D lidar SLAM on a sensor log.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run one algorithm on one log and write map, trajectory, stats")
    r.add_argument("--algo", required=True, help="algorithm name (see `list`)")
    r.add_argument("--log", required=True, help="sensor log (.npz)")
    r.add_argument("--out", help="output directory (required unless --explain)")
    r.add_argument("--config", default=None, help="YAML with config overrides")
    r.add_argument("--explain", action="store_true",
                   help="print each config value derived from the log's sensors, the rule that "
                        "gave it and whether --config overrides it; run nothing")
    r.add_argument("--seed", type=non_negative_int, default=0,
                   help="random seed, a non-negative integer (default 0)")
    r.add_argument("--quiet", action="store_true", help="print nothing on success")
    sub.add_parser("list", help="list the algorithms")
    f = sub.add_parser("fields", help="print an algorithm's config fields as a Markdown table")
    f.add_argument("algo", help="algorithm name (see `list`)")
    f.add_argument("--update", metavar="PAGE", help="write the table into PAGE between its "
                   "<!-- fields --> markers instead")
    return p


def cmd_explain(algo: str, log: str, config: str | None = None) -> str:
    """A Markdown table of the values `algo` derives from the log (path, value, rule, and
    whether `config` sets the path instead)."""
    from sim.logs import read_log
    from slam.registry import explain_config

    rows = explain_config(algo, config, read_log(log))
    lines = [f"{algo} on {log}: {len(rows)} values derived from the log's sensors", "",
             "| field | value | rule |", "|---|---|---|"]
    for d, overridden in rows:
        value = f"{d.value:.6g}" if isinstance(d.value, float) else str(d.value).lower() \
            if isinstance(d.value, bool) else str(d.value)
        note = " (--config sets it instead)" if overridden else ""
        lines.append(f"| {d.path} | {value} | {d.rule}{note} |")
    return "\n".join(lines)


def cmd_run(algo: str, log: str, out: str, config: str | None = None, seed: int = 0) -> dict:
    """Run `algo` on the log file, write the result files into `out`; returns the stats."""
    from sim.logs import read_log
    from slam.io import write_result
    from slam.replay import run_algorithm

    check_out_dir(out)
    result = run_algorithm(algo, read_log(log), config=config, seed=seed)
    write_result(result, out)
    return result.stats


def cmd_list() -> list[str]:
    """One line per known algorithm (built-ins and entry-point plugins): name, class, and
    what it needs from the log."""
    from slam.registry import algorithms

    lines = []
    for name, cls in algorithms().items():
        needs = [w for w, flag in (("odometry", cls.needs_odometry),
                                   ("ground truth", cls.uses_ground_truth)) if flag]
        lines.append(f"{name:<8} {cls.__module__}.{cls.__qualname__}"
                     + (f"  (needs {', '.join(needs)})" if needs else ""))
    return lines


def cmd_fields(algo: str, update: str | None = None) -> str:
    """The field table of `algo`; with `update`, also written into that Markdown page."""
    from pathlib import Path

    from slam.fields import field_table, with_field_table
    from slam.registry import get
    from worlds.yamlio import InputError, atomic_write_text

    cls = get(algo).config_class
    if update is None:
        return field_table(cls)
    page = Path(update)
    try:
        atomic_write_text(page, with_field_table(page.read_text(), cls))
    except (OSError, ValueError) as err:
        raise InputError(f"{page}: {err}") from None
    return f"{page}: field table of {algo} written"


def _dispatch(args) -> None:
    if args.command == "list":
        for line in cmd_list():
            print(line)
    elif args.command == "fields":
        print(cmd_fields(args.algo, args.update), end="" if args.update is None else "\n")
    elif args.explain:
        print(cmd_explain(args.algo, args.log, args.config))
    else:
        if not args.out:
            from worlds.yamlio import InputError
            raise InputError("run: --out is required (or --explain)")
        stats = cmd_run(args.algo, args.log, args.out, args.config, args.seed)
        if not args.quiet:
            print(f"{args.algo}: {stats['scans_processed']} scans in {stats['wall_time_s']:.2f} s "
                  f"({stats['realtime_factor']:.1f}x real time) -> {args.out}")


def main(argv: list[str] | None = None) -> int:
    return run_cli(build_parser, _dispatch, argv)


if __name__ == "__main__":
    sys.exit(main())
