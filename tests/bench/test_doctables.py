"""Result tables in README.md and docs/ are the committed run summaries' tables, byte for byte."""
from pathlib import Path

import pytest

from bench.doctables import RUNS_DIR, stale_blocks, table_under, update_page
from worlds.yamlio import InputError

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SUMMARY = """# Benchmark summary

## Table 1: ADNN (cells), mean ± std

| world | pf |
|---|---|
| swirl_s | 0.00 ± 0.00 |

## Table 2: precision (P) and sensitivity (S)

Surface form.

| world | pf P | pf S |
|---|---|---|
| swirl_s | 0.999 ± 0.001 | 1.000 ± 0.000 |
"""
PAGE = """Intro.

<!-- table: demo | Table 2: precision -->
| old |
<!-- /table -->

<!-- table: other | Table 1 -->
| kept |
<!-- /table -->
"""


def test_the_table_under_a_heading_is_its_pipe_lines():
    assert table_under(SUMMARY, "Table 1") == "| world | pf |\n|---|---|\n| swirl_s | 0.00 ± 0.00 |\n"
    assert table_under(SUMMARY, "Table 2: precision").startswith("| world | pf P | pf S |\n")
    with pytest.raises(InputError, match="s.md: no heading starting with 'Table 9'"):
        table_under(SUMMARY, "Table 9", "s.md")


def test_update_refills_only_the_named_runs_blocks():
    page, count = update_page(PAGE, "demo", SUMMARY)
    assert count == 1
    assert table_under(SUMMARY, "Table 2") in page and "| old |" not in page
    assert "| kept |" in page


def test_a_table_edited_by_hand_is_stale(tmp_path):
    (tmp_path / "demo.md").write_text(SUMMARY)
    page, _ = update_page(PAGE, "demo", SUMMARY)
    assert stale_blocks(page, tmp_path) == ["other | Table 1"]   # its summary is missing
    edited = page.replace("0.999 ± 0.001", "0.990 ± 0.001")
    assert stale_blocks(edited, tmp_path) == ["demo | Table 2: precision", "other | Table 1"]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_committed_tables_are_what_their_run_summaries_give(page):
    stale = stale_blocks(page.read_text(encoding="utf-8"), ROOT / RUNS_DIR)
    assert not stale, (f"{page.relative_to(ROOT)}: tables that differ from their run's summary: "
                       f"{stale} (python -m bench report RUN --update {page.relative_to(ROOT)})")


def test_update_docs_stores_the_summary_and_refills_the_pages(tmp_path):
    from bench.doctables import update_docs
    summary = tmp_path / "run" / "summary.md"
    summary.parent.mkdir()
    summary.write_text(SUMMARY)
    page = tmp_path / "page.md"
    page.write_text(PAGE)
    assert update_docs(summary, [str(page)], "demo", tmp_path) == [f"{page}: 1 table from demo"]
    assert (tmp_path / RUNS_DIR / "demo.md").read_text() == SUMMARY
    assert stale_blocks(page.read_text(), tmp_path / RUNS_DIR) == ["other | Table 1"]
    with pytest.raises(InputError, match="no table marked '<!-- table: typo"):
        update_docs(summary, [str(page)], "typo", tmp_path)
    with pytest.raises(InputError, match="--run-name: name: '../x'"):
        update_docs(summary, [str(page)], "../x", tmp_path)
