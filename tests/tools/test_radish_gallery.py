"""tools/radish_gallery.py on a short CARMEN excerpt: the log's own poses as a column, and each
row's ATE against them."""
import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("radish_gallery", ROOT / "tools" / "radish_gallery.py")
rg = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rg)


def test_gallery_maps_the_logs_poses_and_scores_each_trajectory_against_them(tmp_path, monkeypatch):
    monkeypatch.setattr(rg, "LOGS", {"csail": "carmen_csail_robotlaser1.log"})
    assert rg.run(ROOT / "tests" / "data", "csail", f"graph,{rg.POSES}", tmp_path, 300, 0) == 0
    rows = {r["algo"]: r for r in json.loads((tmp_path / "gallery.json").read_text())}
    assert set(rows) == {"graph", rg.POSES}
    assert rows[rg.POSES]["ate_to_log_poses_m"] == pytest.approx(0.0, abs=1e-9)
    # graph starts from the same (corrected) poses and its scans agree with them
    assert 0.0 < rows["graph"]["ate_to_log_poses_m"] < 0.1
    assert (tmp_path / "csail_poses.png").stat().st_size > 0
    md = (tmp_path / "gallery.md").read_text()
    assert "ATE to the log's poses (m)" in md and "![csail poses](csail_poses.png)" in md
