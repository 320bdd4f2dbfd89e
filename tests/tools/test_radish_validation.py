"""tools/radish_validation.py: the synthetic raw log and the relation matching."""
import importlib.util
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from metrics.relations import Relations
from sim.logs import SensorLog
from slam.pose import relative

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("radish_validation", ROOT / "tools" / "radish_validation.py")
rv = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = rv  # its dataclass looks its module up
_spec.loader.exec_module(rv)


def _corrected_log(n=201):
    # 0.1 m steps along x, then a turn in place of 0.05 rad per step for the last 60
    t = np.arange(n) * 0.1
    pose = np.zeros((n, 3))
    pose[:141, 0] = np.arange(141) * 0.1
    pose[141:, 0] = 14.0
    pose[141:, 2] = np.arange(1, n - 140) * 0.05
    return SensorLog(scan_t=t, scan_ranges=np.full((n, 4), 2.0), scan_angles=np.linspace(-1, 1, 4),
                     odom_t=t, odom_pose=pose)


def test_synthetic_raw_log_perturbs_odometry_and_keeps_gmappings_scans():
    log = _corrected_log()
    a = rv.synthetic_raw_log(log, 0.5, seed=1)
    b = rv.synthetic_raw_log(log, 0.5, seed=1)
    c = rv.synthetic_raw_log(log, 0.5, seed=2)
    assert np.array_equal(a.odom_pose, b.odom_pose) and not np.allclose(a.odom_pose, c.odom_pose)
    assert len(a.odom_t) == log.n_scans and np.allclose(a.odom_pose[0], log.odom_pose[0])
    # the perturbation is GMapping's: proportional to the step, so it drifts but stays small per step
    step_err = relative(a.odom_pose[:-1], a.odom_pose[1:]) - relative(log.odom_pose[:-1], log.odom_pose[1:])
    assert 0 < np.abs(step_err[:, 0]).max() < 0.1
    # kept scans: the first, then about every 1 m of (perturbed) travel or 0.5 rad of turn
    kept = np.searchsorted(log.scan_t, a.scan_t)
    assert kept[0] == 0 and a.scan_ranges.shape == (len(kept), 4)
    gaps = relative(a.odom_pose[kept[:-1]], a.odom_pose[kept[1:]])
    assert np.all((np.hypot(gaps[:, 0], gaps[:, 1]) >= 1.0) | (np.abs(gaps[:, 2]) >= 0.5))
    assert 13 <= (kept <= 140).sum() <= 16 and (kept > 140).sum() >= 5
    assert not a.has_ground_truth


def test_matched_relations_moves_the_clock_and_drops_far_ends():
    rel = Relations(np.array([100.0, 100.5, 101.26]), np.array([101.0, 102.0, 103.0]), np.zeros((3, 3)))
    got = rv.matched_relations(rel, np.array([0.0, 0.5, 1.0, 2.0]), offset=100.0, tol=0.02)
    assert np.allclose(got.t1, [0.0, 0.5]) and np.allclose(got.t2, [1.0, 2.0])


def test_write_logset_leaves_out_a_log_the_checks_refuse_and_says_why(tmp_path, monkeypatch, capsys):
    good = rv.synthetic_raw_log(_corrected_log(), 0.5, seed=1)
    bent = good.odom_pose.copy()
    bent[50:, 0] += 5.0                      # 5 m in one 0.1 s step: no robot, a broken log
    monkeypatch.setattr(rv, "import_log", lambda path: _corrected_log())
    monkeypatch.setattr(rv, "read_relations", lambda path: Relations(np.zeros(0), np.zeros(0), np.zeros((0, 3))))
    monkeypatch.setattr(rv, "synthetic_raw_log",
                        lambda log, scale, seed: good if seed else replace(good, odom_pose=bent))
    code = rv.write_logset(tmp_path, ["fr079"], [0, 1], 0.5, tmp_path)
    err = capsys.readouterr().err
    assert code == 1
    assert "fr079_s0.npz: odom_pose[50]: jumps" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "fr079_s0.npz").exists() and (tmp_path / "fr079_s1.npz").exists()
    listed = (tmp_path / "radish_validation.yaml").read_text()
    assert "fr079_s1.npz" in listed and "fr079_s0" not in listed


def test_an_unknown_log_is_one_line_and_exit_2_before_any_work(tmp_path, capsys):
    assert rv.main(["--logs", "intel,nowhere", "--write", str(tmp_path / "set")]) == 2
    assert capsys.readouterr().err == "error: --logs nowhere: unknown log (known: intel, fr079)\n"
    assert not (tmp_path / "set").exists()
