"""tools/surface_metric.py on a small set (two generated worlds of two kinds, one draw): the
same checks the full run makes (docs/metrics.md), and the drift it draws."""
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("surface_metric", ROOT / "tools" / "surface_metric.py")
sm = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = sm
_spec.loader.exec_module(sm)


def test_drift_is_smooth_bounded_and_centred():
    t = np.linspace(0.0, 100.0, 501)
    d = sm.smooth_drift(t, 0.02, phase=1.0)
    assert np.abs(d).max() <= 0.02 + 1e-12 and np.abs(d).max() > 0.019
    assert np.abs(d.mean(axis=0)).max() < 1e-3
    assert np.abs(np.diff(d, axis=0)).max() < 0.02 * 2 * np.pi / 500 + 1e-9


def test_turn_about_centroid_keeps_the_centroid():
    from slam.pose import compose
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(0, 8, 50), rng.uniform(0, 5, 50), rng.uniform(-3, 3, 50)])
    turned = compose(sm.turn_about_centroid(poses, 0.003), poses)
    c = poses[:, :2].mean(axis=0)
    assert np.allclose(turned[:, :2].mean(axis=0), c)
    assert np.allclose(turned[:, 2] - poses[:, 2], 0.003)
    assert np.allclose(np.linalg.norm(turned[:, :2] - c, axis=1), np.linalg.norm(poses[:, :2] - c, axis=1))


def test_checks_fail_on_bad_numbers():
    row = {"ref": "office:0", "world": "office_s0", "draw": 0, "shift": 0.0, "p": 0.99,
           "s": 0.94, "moved_p": 0.3, "moved_s": 0.1,
           **{f"drift_{a:g}": v for a, v in zip(sm.DRIFTS, (0.9, 0.95, 0.8, 0.7))},
           **{f"turn_{a:g}": 0.95 for a in sm.TURNS}, **{f"turn_exact_{a:g}": 0.97 for a in sm.TURNS}}
    shifted = {**row, "shift": 0.01, "p": 0.96}
    result = {name: ok for name, ok, _ in sm.checks([row, shifted])}
    assert result == {"oracle P and S on every map": False, "oracle P and S on average": False,
                      "world shift moves P and S": False,
                      "map moved one cell diagonally, no alignment": False,
                      "drift maps score lower at each step (F1)": False,
                      "turned maps score as under the exact inverse turn": False}


def test_drift_check_reads_the_four_drift_maps_and_reports_the_first_step_apart():
    # walls in the middle of their cells: the 1 cm map scores as the oracle's, then falls
    row = {"ref": "rectangle_m", "world": "rectangle_m", "draw": 0, "shift": 0.0, "p": 0.995,
           "s": 1.0, "moved_p": 0.01, "moved_s": 0.01,
           **{f"drift_{a:g}": v for a, v in zip(sm.DRIFTS, (0.9990, 0.91, 0.86, 0.68))},
           **{f"turn_{a:g}": 0.99 for a in sm.TURNS}, **{f"turn_exact_{a:g}": 0.99 for a in sm.TURNS}}
    result = {name: ok for name, ok, _ in sm.checks([row])}
    assert result["drift maps score lower at each step (F1)"]
    assert "on 0/1 worlds; not (F1 change): rectangle_m +0.0015" in sm.first_drift_step([row])
    row["drift_0.035"] = 0.92
    assert not {name: ok for name, ok, _ in sm.checks([row])}["drift maps score lower at each step (F1)"]


@pytest.mark.slow
def test_small_run_passes_every_check(capsys):
    from metrics.surface import DEFAULT_TAU_M
    refs = ["office:0", "loop:0"]
    rows = sm.run(refs, refs, draws=1, tau=DEFAULT_TAU_M, jobs=1)
    results = sm.checks(rows)
    assert len(results) == 8
    failed = [(name, detail) for name, ok, detail in results if not ok]
    assert not failed, failed
    # a turned map read under the exact inverse turn scores as the map itself
    for r in rows:
        if "moved_p" in r:
            base = sm._f1(r["p"], r["s"])
            assert all(r[f"turn_exact_{a:g}"] >= base - 0.01 for a in sm.TURNS), r
