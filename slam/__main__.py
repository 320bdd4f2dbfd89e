"""Command line: `python -m slam run --algo NAME --log LOG --out DIR [--config YAML] [--seed S]`,
`python -m slam list`. User errors print one line `error: ...` and exit with code 2."""
from __future__ import annotations

import argparse
import sys


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m slam", description="Run a 2D lidar SLAM on a sensor log.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run one algorithm on one log and write map, trajectory, stats")
    r.add_argument("--algo", required=True, help="algorithm name (see `list`)")
    r.add_argument("--log", required=True, help="sensor log (.npz)")
    r.add_argument("--out", required=True, help="output directory")
    r.add_argument("--config", default=None, help="YAML with config overrides")
    r.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    r.add_argument("--quiet", action="store_true", help="print nothing on success")
    sub.add_parser("list", help="list the algorithms")
    return p


def cmd_run(algo: str, log: str, out: str, config: str | None = None, seed: int = 0) -> dict:
    """Run `algo` on the log file, write the result files into `out`; returns the stats."""
    from sim.log import read_log
    from slam.base import run_algorithm
    from slam.io import write_result

    result = run_algorithm(algo, read_log(log), config=config, seed=seed)
    write_result(result, out)
    return result.stats


def cmd_list() -> list[str]:
    """Names of the registered algorithms."""
    from slam.base import ALGORITHMS, _ensure_builtin_algorithms

    _ensure_builtin_algorithms()
    return sorted(ALGORITHMS)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from worlds.yamlio import InputError

    try:
        if args.command == "list":
            for name in cmd_list():
                print(name)
        else:
            stats = cmd_run(args.algo, args.log, args.out, args.config, args.seed)
            if not args.quiet:
                print(f"{args.algo}: {stats['scans_processed']} scans in {stats['wall_time_s']:.2f} s "
                      f"({stats['realtime_factor']:.1f}x real time) -> {args.out}")
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
