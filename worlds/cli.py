"""What every package's command line shares (each __main__.py stays thin).

- `Parser`: argparse whose errors are one line, `error: --flag: problem`, as InputError.
- Flag types, checked at parse time: `integer(lo, hi)`, `number(lo, hi, above)` and the
  common cases `non_negative_int`, `positive_int`, `finite_float`, `positive_float`,
  `non_negative_float`, `share_0_1`.
- `check_out_dir`, `check_out_file`: refuse an output path that cannot be written before
  the work starts.
- `run_cli(build_parser, command, argv)`: the boundary of every main(): InputError and
  OSError give one line on stderr and exit 2, Ctrl-C gives `interrupted` and exit 130.
"""
from __future__ import annotations

import argparse
import errno
import math
import os
import re
import sys
from pathlib import Path
from typing import Callable

from worlds.yamlio import InputError

__all__ = ["Parser", "integer", "number", "non_negative_int", "positive_int", "finite_float",
           "positive_float", "non_negative_float", "share_0_1", "check_out_dir",
           "check_out_file", "run_cli", "EXIT_USAGE", "EXIT_INTERRUPTED"]

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130   # 128 + SIGINT, as a shell reports it


class Parser(argparse.ArgumentParser):
    """argparse.ArgumentParser that raises InputError('--flag: problem') instead of printing
    the usage and exiting (subparsers inherit it)."""

    def error(self, message: str):
        m = re.match(r"argument ([^:]+): (.*)", message, re.S)
        if m:
            message = f"{m[1].split('/')[0]}: {m[2]}"
        raise InputError(message)


def integer(lo: int | None = None, hi: int | None = None) -> Callable[[str], int]:
    """A flag type: an integer in [lo, hi] (None: unbounded)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            bound = f">= {lo}" if hi is None else f"<= {hi}" if lo is None else f"in {lo}..{hi}"
            raise argparse.ArgumentTypeError(f"must be an integer {bound}, got {text!r}")
        return value
    return parse


def number(lo: float | None = None, hi: float | None = None,
           above: float | None = None) -> Callable[[str], float]:
    """A flag type: a finite float in [lo, hi] and > above (None: no such bound)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
        if above is not None and not value > above:
            raise argparse.ArgumentTypeError(
                f"must be positive, got {text!r}" if above == 0 else f"must be > {above:g}, got {text!r}")
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            bound = (f">= {lo:g}" if hi is None else f"<= {hi:g}" if lo is None
                     else f"in [{lo:g}, {hi:g}]")
            raise argparse.ArgumentTypeError(f"must be {bound}, got {text!r}")
        return value
    return parse


non_negative_int = integer(0)
positive_int = integer(1)
finite_float = number()
positive_float = number(above=0.0)
non_negative_float = number(lo=0.0)
share_0_1 = number(0.0, 1.0)


def _check_writable(path: Path, folder: Path) -> None:
    """InputError naming `path` unless `folder` is, or can be made, a writable folder."""
    d = folder.absolute()
    while not d.exists() and d.parent != d:
        d = d.parent
    if not d.is_dir():
        raise InputError(f"{path}: {os.strerror(errno.ENOTDIR)} ({d} is a file)")
    if not os.access(d, os.W_OK | os.X_OK):
        raise InputError(f"{path}: {os.strerror(errno.EACCES)} ({d} is not writable)")


def check_out_dir(path: str | os.PathLike, flag: str = "--out") -> Path:
    """The output folder `path`, checked before any work: a folder (or nothing yet) that can
    be written. Creates nothing; raises InputError naming the path."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f"{p}: {flag} must be a folder, this is a file")
    _check_writable(p, p)
    return p


def check_out_file(path: str | os.PathLike, flag: str = "--out") -> Path:
    """The output file `path`, checked before any work: not a folder, and its folder can be
    written. Creates nothing; raises InputError naming the path."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p}: {flag} must be a file, this is a folder")
    _check_writable(p, p.parent)
    return p


def _os_error_line(err: OSError) -> str:
    name = err.filename if err.filename is not None else err.filename2
    reason = err.strerror or str(err)
    return f"{name}: {reason}" if name is not None else reason


def run_cli(build_parser: Callable[[], argparse.ArgumentParser],
            command: Callable[[argparse.Namespace], int | None],
            argv: list[str] | None = None) -> int:
    """Parse `argv` and run `command(args)`; returns the exit code (None counts as 0).

    A user error (InputError, a bad flag) or a file-system error (OSError) prints
    `error: ...` on one line and gives 2; Ctrl-C prints `interrupted` and gives 130.
    Other exceptions are bugs and keep their traceback.
    """
    try:
        args = build_parser().parse_args(argv)
        return command(args) or 0
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
    except OSError as err:
        print(f"error: {_os_error_line(err)}", file=sys.stderr)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_USAGE
