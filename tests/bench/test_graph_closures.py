"""Smoke test of bench_scripts/graph_closures.py: both modes run on a recorded log and print a row."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

from sim import record, write_log
from worlds import load_world

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def swirl_s_logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    write_log(record(load_world("swirl_s"), seed=0), d / "swirl_s.npz")
    return d


def _script(*args):
    out = subprocess.run([sys.executable, str(ROOT / "bench_scripts" / "graph_closures.py"), *args],
                         capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert out.returncode == 0, out.stderr
    return out.stdout


@pytest.mark.slow
def test_counts_matches_against_the_truth(swirl_s_logs):
    row = _script("--logs", str(swirl_s_logs)).splitlines()[-1].split()
    assert row[0] == "swirl_s"
    matches, good, good_rejected, false, false_rejected = (int(v) for v in row[1:6])
    # swirl_s closes its loops: most matches are good, and the check keeps the good ones
    assert matches > 50 and good > 0.8 * matches and good_rejected <= 0.01 * good
    assert false <= matches - good and false_rejected <= false


@pytest.mark.slow
def test_oracle_filter_scores_the_run(swirl_s_logs):
    last = _script("--logs", str(swirl_s_logs), "--oracle-filter", "0.01,0.2").splitlines()[-1]
    m = re.match(r"swirl_s\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+(\d+)/(\d+)$", last)
    assert m, last
    precision, sensitivity = float(m[1]), float(m[2])
    kept, found = int(m[5]), int(m[6])
    assert 0 < kept < found and precision > 0.9 and sensitivity > 0.9
