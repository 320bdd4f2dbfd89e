"""`write_report(DIR)`: summary.md, summary.csv and the figures, rebuilt from results.json."""
from __future__ import annotations

from pathlib import Path

from bench.figures import write_figures
from bench.results import RUN_NAME, read_rows, read_run
from bench.tables import write_tables

__all__ = ["write_report"]


def write_report(out_dir: str | Path, figures: bool = True) -> Path:
    """Rebuild the report of run directory `out_dir`; returns the path of summary.md.

    Needs DIR/results.json; DIR/run.json (arguments, versions) and DIR/maps (arrays for the
    figures) are used when present. InputError if results.json is missing or malformed.
    """
    out_dir = Path(out_dir)
    rows = read_rows(out_dir)
    run = read_run(out_dir) if (out_dir / RUN_NAME).is_file() else None
    made = write_figures(out_dir, rows, run) if figures and rows else {}
    return write_tables(out_dir, rows, run, made)
