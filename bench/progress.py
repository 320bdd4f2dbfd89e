"""A one-line progress bar on stderr (no dependency); plain lines when stderr is not a TTY."""
from __future__ import annotations

import sys
import time

__all__ = ["Progress", "format_seconds"]


def format_seconds(s: float) -> str:
    """12.3 -> '0:12', 3725 -> '1:02:05'."""
    if s != s or s == float("inf"):
        return "?"
    s = int(round(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


class Progress:
    """done/total, the current item, elapsed time and ETA.

    total: tasks to do in this session; already: rows done before (resume), shown but not
    counted in the ETA. ETA = elapsed / done * remaining (tasks are of similar size per world).
    """

    def __init__(self, total: int, already: int = 0, stream=None, enabled: bool = True):
        self.total = total
        self.already = already
        self.done = 0
        self.failed = 0
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.monotonic()
        self._width = 0

    def line(self, label: str) -> str:
        elapsed = time.monotonic() - self.t0
        left = self.total - self.done
        eta = elapsed / self.done * left if self.done else float("nan")
        n, N = self.already + self.done, self.already + self.total
        frac = n / N if N else 1.0
        bar = "#" * int(frac * 20)
        fail = f" {self.failed} failed" if self.failed else ""
        return (f"[{bar:<20}] {n}/{N}{fail} {label} | elapsed {format_seconds(elapsed)} "
                f"ETA {format_seconds(eta) if left else '0:00'}")

    def note(self, label: str) -> None:
        """Show what is going on without finishing a task (TTY only: not worth a line)."""
        if self.enabled and self.tty:
            self._write(self.line(label))

    def advance(self, label: str, ok: bool = True) -> None:
        """One task finished."""
        self.done += 1
        self.failed += 0 if ok else 1
        if not self.enabled:
            return
        text = self.line(label + ("" if ok else " FAILED"))
        if self.tty:
            self._write(text)
        else:
            print(text, file=self.stream, flush=True)

    def _write(self, text: str) -> None:
        pad = max(0, self._width - len(text))
        self.stream.write("\r" + text + " " * pad)
        self.stream.flush()
        self._width = len(text)

    def close(self) -> None:
        if self.enabled and self.tty and self._width:
            self.stream.write("\n")
            self.stream.flush()
            self._width = 0
