"""docs/extending.md's algorithm recipe, installed as a package with its entry point, runs
through `slam list`, `slam run` and `bench run` (fresh processes, as a user runs them)."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from sim.logs import write_log
from tests.slam.synthlog import box_room_segments, make_log

ROOT = Path(__file__).resolve().parents[2]
TINY = ROOT / "tests" / "bench" / "tiny_world.yaml"


def _recipe() -> tuple[str, dict]:
    """(the module's source, the entry points) as docs/extending.md gives them."""
    text = (ROOT / "docs" / "extending.md").read_text()
    section = text.split("## Adding an algorithm", 1)[1].split("\n## ", 1)[0]
    module = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    toml = re.search(r"```toml\n(.*?)```", section, re.S).group(1)
    return module, tomllib.loads(toml)["project"]["entry-points"]


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A site folder holding my_slam.py and its dist-info (what pip install writes)."""
    site = tmp_path_factory.mktemp("site")
    module, groups = _recipe()
    (site / "my_slam.py").write_text(module)
    info = site / "my_slam-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-slam\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("".join(
        f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in eps.items()) for group, eps in groups.items()))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), str(ROOT)]),
               SLAM_BENCH_CACHE=str(tmp_path_factory.mktemp("cache")))
    return env


def _run(args, env, cwd):
    return subprocess.run([sys.executable, "-m", *args], env=env, cwd=cwd, capture_output=True,
                          text=True, timeout=600)


@pytest.mark.slow
def test_entry_point_plugin_runs_through_slam_and_bench(installed, tmp_path):
    listed = _run(["slam", "list"], installed, tmp_path)
    assert listed.returncode == 0, listed.stderr
    assert re.search(r"^odometry\s+my_slam\.OdometrySlam\s+\(needs odometry\)", listed.stdout, re.M)

    log = tmp_path / "room.npz"
    write_log(make_log(box_room_segments(), np.array([[1.0, 1.0], [3.0, 1.0]]), seed=2), log)
    ran = _run(["slam", "run", "--algo", "odometry", "--log", str(log), "--out", str(tmp_path / "o")],
               installed, tmp_path)
    assert ran.returncode == 0, ran.stderr
    stats = json.loads((tmp_path / "o" / "stats.json").read_text())
    assert stats["algo"] == "odometry" and stats["scans_processed"] > 0

    out = tmp_path / "bench"
    bench = _run(["bench", "run", "--world", str(TINY), "--algo", "odometry,oracle", "--repeats", "1",
                  "--jobs", "1", "--no-figures", "--out", str(out)], installed, tmp_path)
    assert bench.returncode == 0, bench.stderr
    rows = json.loads((out / "results.json").read_text())
    rows = rows["rows"] if isinstance(rows, dict) else rows
    ours = [r for r in rows if r["algo"] == "odometry"]
    assert ours and all(r["status"] == "ok" for r in ours), ours
    assert "odometry" in (out / "summary.md").read_text()
