"""A metric registered once reaches the score dict, the benchmark row, summary.csv, summary.md
and regress, with no other file edited: docs/extending.md's recipe, run as written."""
import csv
import io
import re
from pathlib import Path

import pytest

from bench.regress import compare, default_tolerances, summarize
from bench.tables import summary_csv, summary_markdown
from bench.task import _score
from metrics import registry
from metrics.score import score_map
from tests.metrics.maps import ROOM, draw


RECIPE = Path(__file__).resolve().parents[2] / "docs" / "extending.md"


@pytest.fixture
def toy():
    section = RECIPE.read_text().split("## Adding a metric", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    exec(compile(code, str(RECIPE), "exec"), {"__name__": "wall_share_recipe"})
    yield
    registry.unregister("wall_share")
    assert "wall_share" not in [c.key for c in registry.columns()]


def _half_walls():
    truth = draw(ROOM)
    prob = truth.prob.copy()
    right = prob[:, truth.cols // 2:]
    right[right >= 0.65] = 0.0
    return truth.with_prob(prob), truth


def _rows():
    return [{"world": "swirl_s", "algo": a, "repeat": r, "status": "ok", "precision": 0.9,
             "wall_share": share + 0.1 * r}
            for a, share in (("pf", 0.5), ("gn", 0.8)) for r in range(2)]


def test_a_registered_metric_reaches_every_report(toy):
    est, truth = _half_walls()
    share = est.occupied().sum() / truth.occupied().sum()
    assert score_map(est, truth)["wall_share"] == pytest.approx(share)
    assert _score(est, truth)["wall_share"] == pytest.approx(share)   # the benchmark row

    rows = _rows()
    header = next(csv.reader(io.StringIO(summary_csv(rows))))
    assert header[-2:] == ["wall_share_mean", "wall_share_std"]

    md = summary_markdown(rows).splitlines()
    i = md.index("### wall share (estimate / truth) (higher is better)")
    assert md[i + 2] == "| world | pf | gn |"
    assert md[i + 4] == "| swirl_s | 0.55 ± 0.07 | 0.85 ± 0.07 |"

    assert default_tolerances()["wall_share"] == ("drop", 0.1)
    base = summarize(rows)
    assert base["swirl_s/pf"]["wall_share"] == pytest.approx(0.55)
    worse = [dict(r, wall_share=0.2) for r in rows]
    assert compare(base, summarize(worse)) == [
        "swirl_s/gn: wall_share dropped from 0.85 to 0.2 (by 0.65, tolerance 0.1)",
        "swirl_s/pf: wall_share dropped from 0.55 to 0.2 (by 0.35, tolerance 0.1)"]


def test_without_values_the_generic_section_stays_out():
    md = summary_markdown([dict(r, f1=None) for r in _rows()])
    assert "## More metrics" not in md and "wall share" not in md
    md = summary_markdown([dict(r, f1=0.5) for r in _rows()])
    assert md.index("## Real-time factor") < md.index("## More metrics") < md.index("### F1")
