"""Run a command line's main() in a forked child and watch it from outside: exit code, stderr,
peak memory and time, and a listing of the files around it before and after.

The child is forked from the test process after the packages are imported, so an example
costs a fork, not an interpreter start. It runs with the warnings filters of a plain
`python -m ...` (not pytest's, which record warnings instead of printing them), so a warning
the user would see lands on its stderr like any other line.

Peak memory: a forked child starts with the resident pages of the test process (which, late
in a full test session, may hold far more than a command's process would), so the peak is
counted as the child's VmHWM minus its VmRSS at the fork, plus `base_kb`: what a fresh
interpreter holds after importing the same packages (`import_baseline_kb`).
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

__all__ = ["Outcome", "run_forked", "import_baseline_kb", "listing", "changed_outside"]

POLL_S = 0.01
# address-space ceiling of the child on top of what it inherits: a safety net for the shared
# machine should a bomb outrun the parent's polling (the 1 GB verdict comes from VmHWM)
_AS_HEADROOM = 6 * 1024**3


@dataclass
class Outcome:
    """How one child ended. code: main()'s return value (or SystemExit's code; None when the
    child was killed or died without reporting); err: its stderr; peak_kb: its peak resident
    memory as a process of its own would have had it (module docstring); killed: why the
    parent killed it ('' if it did not); seconds: wall time."""

    code: object
    err: str
    peak_kb: int
    killed: str
    seconds: float

    @property
    def err_lines(self) -> list[str]:
        return self.err.strip().splitlines()


def _status_kb(pid: int | str, key: str) -> int:
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith(key + ":"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _child(main: Callable[[list[str]], int], argv: list[str], cwd: Path, env: dict[str, str],
           err_fd: int, report_fd: int, guards: Callable[[], None] | None) -> None:
    """Body of the forked child; never returns."""
    code: object = None
    try:
        os.setpgid(0, 0)
        import resource
        vm = _status_kb("self", "VmSize") * 1024
        resource.setrlimit(resource.RLIMIT_AS, (vm + _AS_HEADROOM, vm + _AS_HEADROOM))
        os.dup2(err_fd, 2)
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        sys.stdout = open(1, "w", closefd=False)
        sys.stderr = open(2, "w", buffering=1, closefd=False)
        os.chdir(cwd)
        os.environ.update(env)
        os.write(report_fd, f"{_status_kb('self', 'VmRSS')}\n".encode())
        if guards is not None:
            guards()
        with warnings.catch_warnings():
            # the filters of `python -m ...` without -W (the warnings module's defaults)
            warnings.resetwarnings()
            warnings.filterwarnings("default", category=DeprecationWarning, module="__main__")
            for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning,
                             ResourceWarning):
                warnings.filterwarnings("ignore", category=category)
            warnings.showwarning = _show_on_stderr
            try:
                code = main(argv)
            except SystemExit as exc:
                code = exc.code
            except BaseException:   # a bug: its traceback, as the interpreter would print it
                traceback.print_exc()
                code = "exception"
        sys.stderr.flush()
        sys.stdout.flush()
        report = json.dumps({"code": code, "hwm_kb": _status_kb("self", "VmHWM")})
        os.write(report_fd, report.encode())
    except BaseException:
        try:
            traceback.print_exc()
        except BaseException:
            pass
    finally:
        os._exit(0)


def _show_on_stderr(message, category, filename, lineno, file=None, line=None):
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


def import_baseline_kb(modules: list[str]) -> int:
    """VmHWM (kB) of a fresh interpreter that imports `modules`."""
    code = (f"import {', '.join(modules)}\n"
            "print([l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM:')][0])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(out.stdout.strip())


def run_forked(main: Callable[[list[str]], int], argv: list[str], cwd: Path,
               env: dict[str, str] | None = None, timeout_s: float = 60.0,
               max_peak_kb: int = 1024 * 1024, base_kb: int = 0,
               guards: Callable[[], None] | None = None) -> Outcome:
    """Fork; the child chdirs to `cwd`, sets `env`, calls `guards()` (e.g. patches that turn
    an unwanted step into an error) and runs `main(argv)` with stdout discarded and stderr
    captured. The parent kills the child's process group when it runs longer than
    `timeout_s` or its peak memory (module docstring; base_kb: the fresh interpreter's)
    passes `max_peak_kb` (killed says which)."""
    read_fd, write_fd = os.pipe()
    err_file = tempfile.TemporaryFile()
    sys.stdout.flush()
    sys.stderr.flush()
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:
        os.close(read_fd)
        _child(main, argv, cwd, dict(env or {}), err_file.fileno(), write_fd, guards)
    os.close(write_fd)
    report = os.fdopen(read_fd, "rb")
    start = int(report.readline() or 0)   # the child's resident memory at the fork
    killed, peak = "", 0
    while True:
        done, _ = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        peak = max(peak, _status_kb(pid, "VmHWM") - start + base_kb)
        elapsed = time.monotonic() - t0
        if peak > max_peak_kb or elapsed > timeout_s:
            killed = (f"peak memory {peak:,} kB passed {max_peak_kb:,} kB" if peak > max_peak_kb
                      else f"still running after {timeout_s:g} s")
            try:
                os.killpg(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            os.waitpid(pid, 0)
            break
        time.sleep(POLL_S)
    seconds = time.monotonic() - t0
    with report:
        raw = report.read()
    err_file.seek(0)
    err = err_file.read().decode("utf-8", errors="replace")
    err_file.close()
    code = None
    if raw and not killed:
        final = json.loads(raw)
        code, peak = final["code"], max(peak, final["hwm_kb"] - start + base_kb)
    return Outcome(code, err, peak, killed, seconds)


def listing(root: Path, skip: tuple[Path, ...] = ()) -> dict[str, tuple[int, int]]:
    """relative path -> (size, mtime_ns) of every file, folder and link under `root` (links
    not followed), leaving out the trees `skip`."""
    out = {}
    skipped = {str(p) for p in skip}
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if os.path.join(folder, d) not in skipped]
        for name in dirs + files:
            p = os.path.join(folder, name)
            if p in skipped:
                continue
            st = os.lstat(p)
            out[os.path.relpath(p, root)] = (st.st_size if not os.path.isdir(p) else 0,
                                             st.st_mtime_ns if not os.path.isdir(p) else 0)
    return out


def changed_outside(before: dict, after: dict) -> list[str]:
    """Paths that appeared, vanished or changed between two listings."""
    return sorted(k for k in before.keys() | after.keys() if before.get(k) != after.get(k))
