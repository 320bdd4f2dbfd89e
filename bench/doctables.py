"""Result tables in the docs, filled from committed run summaries, so no number is typed by hand.

A table in a Markdown page sits between two markers naming a committed summary and a heading
of it:

    <!-- table: world_all | Table 2: precision (P) -->
    | world | pf P | ...
    <!-- /table -->

`world_all` is `docs/runs/world_all.md`, the summary.md of a run copied there by
`python -m bench report RUN --update PAGE --run-name world_all`; the heading is matched by its
start. `update_page` refills every block of one run; `stale_blocks` lists the blocks whose
table differs from what their summary gives (the test of the committed docs).
"""
from __future__ import annotations

import re
from pathlib import Path

from worlds.yamlio import InputError, atomic_write_text

__all__ = ["RUNS_DIR", "table_under", "update_page", "stale_blocks", "store_summary",
           "update_docs"]

RUNS_DIR = Path("docs") / "runs"
_BLOCK = re.compile(r"(<!-- table: *(?P<run>[\w.+-]+) *\| *(?P<heading>[^>]*?) *-->\n)"
                    r"(?P<body>.*?)(<!-- /table -->)", re.S)


def table_under(summary: str, heading: str, where: str = "summary") -> str:
    """The Markdown table (its `|` lines, newline-terminated) that first follows the heading of
    `summary` starting with `heading`; InputError naming `where` when there is none."""
    lines = summary.splitlines()
    starts = [i for i, line in enumerate(lines)
              if line.startswith("#") and line.lstrip("#").strip().startswith(heading)]
    if not starts:
        raise InputError(f"{where}: no heading starting with {heading!r}")
    rows = []
    for line in lines[starts[0] + 1:]:
        if line.startswith("#"):
            break
        if line.startswith("|"):
            rows.append(line)
        elif rows:
            break
    if not rows:
        raise InputError(f"{where}: no table under {heading!r}")
    return "\n".join(rows) + "\n"


def update_page(page: str, run_name: str, summary: str) -> tuple[str, int]:
    """`page` with every block naming `run_name` refilled from `summary`; and how many."""
    count = 0

    def fill(m: re.Match) -> str:
        nonlocal count
        if m["run"] != run_name:
            return m[0]
        count += 1
        return m[1] + table_under(summary, m["heading"], run_name) + m[5]
    return _BLOCK.sub(fill, page), count


def stale_blocks(page: str, runs_dir: Path) -> list[str]:
    """'<run> | <heading>' of every block of `page` whose table is not what runs_dir/<run>.md
    gives (or whose summary is missing)."""
    out = []
    for m in _BLOCK.finditer(page):
        summary = runs_dir / f"{m['run']}.md"
        want = (table_under(summary.read_text(encoding="utf-8"), m["heading"], str(summary))
                if summary.is_file() else None)
        if m["body"] != want:
            out.append(f"{m['run']} | {m['heading']}")
    return out


def store_summary(summary_path: Path, run_name: str, root: Path) -> Path:
    """Copy a run's summary.md to root/docs/runs/<run_name>.md (the committed summary)."""
    from worlds.paths import check_name, path_inside
    check_name(run_name, "--run-name", "name")
    target = path_inside(root / RUNS_DIR, f"{run_name}.md")
    atomic_write_text(target, summary_path.read_text(encoding="utf-8"), root=root / RUNS_DIR)
    return target


def update_docs(summary_path: Path, pages: list[str], run_name: str, root: Path) -> list[str]:
    """Store the run's summary as root/docs/runs/<run_name>.md and refill every block naming
    it in `pages`; one line per page saying how many tables it took. InputError for a page
    without such a block (a typo in --run-name would otherwise change nothing silently)."""
    store_summary(summary_path, run_name, root)
    summary = summary_path.read_text(encoding="utf-8")
    done = []
    for page in pages:
        p = Path(page)
        try:
            text = p.read_text(encoding="utf-8")
        except OSError as err:
            raise InputError(f"{p}: cannot read: {err.strerror}") from None
        new, count = update_page(text, run_name, summary)
        if count == 0:
            raise InputError(f"{p}: no table marked '<!-- table: {run_name} | ... -->'")
        if new != text:
            atomic_write_text(p, new)
        done.append(f"{p}: {count} table{'s' if count > 1 else ''} from {run_name}")
    return done
