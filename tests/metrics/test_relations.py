"""Kuemmerle relations metric: hand-computed cases, lookups, file reading, the CSAIL figures."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from metrics.relations import (Relations, add_relations_arguments, lookup_poses, read_relations,
                               write_relations,
                               relation_errors, relations_error, relations_from_files,
                               relations_main)
from worlds.yamlio import InputError

DATA = Path(__file__).resolve().parents[1] / "data"
RADISH = Path(__file__).resolve().parents[3] / "shared" / "data" / "radish"
H = np.pi / 2


def _write_tum(path: Path, t, poses) -> None:
    lines = [f"{ti:.6f} {x:.9f} {y:.9f} 0 0 0 {np.sin(a / 2):.12f} {np.cos(a / 2):.12f}"
             for ti, (x, y, a) in zip(t, poses)]
    path.write_text("\n".join(lines) + "\n")


# --- hand-computed -----------------------------------------------------------------------------

def test_errors_hand_computed():
    # estimated motion 0 -> 1: one metre ahead, then a quarter turn left
    p1 = np.array([[0.0, 0.0, 0.0]] * 3)
    p2 = np.array([[1.0, 0.0, H]] * 3)
    delta = np.array([[1.0, 0.0, H],          # exact: no error
                      [1.1, 0.0, H],          # 0.1 m longer: E = (1,0,H)(0,1.1,-H) = (-0.1,0,0)
                      [1.0, 0.0, H + 0.1]])   # 0.1 rad more: t(E) = (1 - cos .1, sin .1)
    trans, rot = relation_errors(p1, p2, delta)
    np.testing.assert_allclose(trans, [0.0, 0.1, 2 * np.sin(0.05)], atol=1e-12)
    np.testing.assert_allclose(rot, [0.0, 0.0, 0.1], atol=1e-12)


def test_statistics_hand_computed():
    t = np.array([0.0, 1.0, 2.0])
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, H], [1.0, 1.0, H]])
    rel = Relations(t1=[0.0, 0.0, 1.0], t2=[1.0, 1.0, 2.0],
                    delta=[[1.1, 0.0, H], [1.0, 0.0, H + 0.1], [1.0, 0.0, 0.0]])
    res = relations_error(t, poses, rel, long_s=1.5)
    e = np.array([0.1, 2 * np.sin(0.05), 0.0])       # m, as in test_errors_hand_computed
    r = np.array([0.0, np.rad2deg(0.1), 0.0])        # deg
    assert res["n_used"] == 3 and res["n_skipped"] == 0
    assert res["abs_trans_mean"] == pytest.approx(e.sum() / 3)
    assert res["abs_trans_std"] == pytest.approx(np.sqrt(((e - e.mean()) ** 2).sum() / 2))
    assert res["sq_trans_mean"] == pytest.approx((e ** 2).sum() / 3)
    assert res["abs_rot_deg_mean"] == pytest.approx(5.729577951 / 3)
    assert res["sq_rot_deg2_mean"] == pytest.approx(r[1] ** 2 / 3)
    assert res["sq_rot_deg2_std"] == pytest.approx(np.std(r ** 2, ddof=1))
    assert res["max_trans"] == pytest.approx(0.1)
    # no relation spans 1.5 s or more
    assert res["short"]["n"] == 3 and res["long"]["n"] == 0


def test_interpolation_midpoint_and_shorter_arc():
    t = np.array([0.0, 1.0])
    p = lookup_poses([0.5], t, np.array([[0.0, 0.0, 0.0], [1.0, 2.0, H]]))
    np.testing.assert_allclose(p, [[0.5, 1.0, H / 2]])
    p = lookup_poses([0.5], t, np.array([[0.0, 0.0, 3.0], [0.0, 0.0, -3.0]]))
    assert abs(abs(p[0, 2]) - np.pi) < 1e-12   # through +-pi, not through 0
    # outside the trajectory: no pose
    assert np.all(np.isnan(lookup_poses([-0.1, 1.2], t, np.zeros((2, 3)))))


def test_odometry_chained_onto_nearest_scan_pose(rng):
    # odometry O(t); the "SLAM" frame is a fixed rigid transform T of it: P = T * O
    ot = np.linspace(0.0, 10.0, 101)
    op = np.stack([np.cos(ot / 3), np.sin(ot / 2), np.unwrap(ot / 4) - 1.0], axis=1)
    c, s, T = np.cos(0.7), np.sin(0.7), np.array([3.0, -2.0, 0.7])

    def to_slam(q):
        return np.stack([T[0] + c * q[:, 0] - s * q[:, 1], T[1] + s * q[:, 0] + c * q[:, 1],
                         np.angle(np.exp(1j * (q[:, 2] + T[2])))], axis=1)

    scan_t = np.array([0.0, 4.0, 10.0])
    scan_p = to_slam(op[[0, 40, 100]])
    tq = rng.uniform(0, 10, 20)
    got = lookup_poses(tq, scan_t, scan_p, odom=(ot, op))
    want = to_slam(np.stack([np.interp(tq, ot, op[:, k]) for k in range(3)], axis=1))
    np.testing.assert_allclose(got, want, atol=1e-9)
    # a trajectory error at one scan moves exactly the queries nearest to that scan
    bad = scan_p.copy()
    bad[1, 0] += 0.5
    moved = np.abs(lookup_poses(tq, scan_t, bad, odom=(ot, op))[:, 0] - got[:, 0]) > 1e-9
    nearest = np.argmin(np.abs(tq[:, None] - scan_t[None, :]), axis=1)
    np.testing.assert_array_equal(moved, nearest == 1)


def test_exact_lookup_uses_only_matching_times():
    t = np.array([10.000001, 11.0, 12.0])
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    rel = Relations([10.0, 10.5], [11.0, 12.0], [[1.0, 0.0, 0.0], [1.5, 0.0, 0.0]])
    res = relations_error(t, poses, rel, lookup="exact", tolerance=1e-5)
    assert res["n_used"] == 1 and res["n_skipped"] == 1
    assert res["abs_trans_mean"] == pytest.approx(0.0)
    assert np.isnan(res["abs_trans_std"])  # one relation: no sample std
    with pytest.raises(InputError, match="unknown lookup"):
        relations_error(t, poses, rel, lookup="nearest")


# --- files -------------------------------------------------------------------------------------

def test_read_relations_excerpt():
    rel = read_relations(DATA / "mit-csail_excerpt.relations")  # two blanks inside each line
    assert len(rel) == 36
    assert rel.t1[0] == pytest.approx(1134864645.90321, abs=1e-6)
    np.testing.assert_allclose(rel.delta[0], [0.31293, 0.02935, 0.24198])


@pytest.mark.parametrize("line, pattern", [
    ("1 2 3 4 5 6 7", "line 2: expected 8 numbers"),
    ("1 2 3 4 5 6 7 x", "line 2: not a number"),
    ("1 2 3 4 0 0.2 0 0", "line 2: roll/pitch"),
    ("1 2 nan 0 0 0 0 0", "line 2: non-finite"),
])
def test_read_relations_errors(tmp_path, line, pattern):
    p = tmp_path / "r.relations"
    p.write_text("0 1 1 0 0 0 0 0\n" + line + "\n")
    with pytest.raises(InputError, match=pattern):
        read_relations(p)


def test_read_relations_empty_and_missing(tmp_path):
    p = tmp_path / "e.relations"
    p.write_text("# nothing\n\n")
    with pytest.raises(InputError, match="no relations"):
        read_relations(p)
    with pytest.raises(InputError, match="file not found"):
        read_relations(tmp_path / "missing")


def test_gfs_excerpt_odometry_against_relation_excerpt(tmp_path, capsys):
    """The raw odometry of the .gfs excerpt, written as TUM, scored through the CLI entry point."""
    from sim.logs.carmen import import_log
    log = import_log(DATA / "csail_excerpt.gfs")
    traj = tmp_path / "odom.tum"
    _write_tum(traj, log.odom_t, log.odom_pose)
    res = relations_from_files(traj, DATA / "mit-csail_excerpt.relations")
    # 8 of the 36 relations lie inside the excerpt's odometry (it ends at 1134864644.83419)
    assert res["n_used"] == 8 and res["n_skipped"] == 28
    # short relations on raw odometry: a few cm (the data README: 0.047 m over all short ones)
    assert 0.005 < res["abs_trans_mean"] < 0.1
    parser = argparse.ArgumentParser()
    add_relations_arguments(parser)
    args = parser.parse_args(["--traj", str(traj), "--relations",
                              str(DATA / "mit-csail_excerpt.relations"), "--json"])
    assert relations_main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_used"] == 8 and out["abs_trans_mean"] == pytest.approx(res["abs_trans_mean"])
    assert out["long"]["abs_trans_std"] is None  # no long relation here: null, not NaN
    args = parser.parse_args(["--traj", str(traj), "--relations",
                              str(DATA / "mit-csail_excerpt.relations"), "--odom",
                              str(DATA / "csail_excerpt.gfs")])
    assert relations_main(args) == 0
    assert "Abs translational error" in capsys.readouterr().out


# --- the figures of the Radish data README ------------------------------------------------------

@pytest.mark.skipif(not RADISH.is_dir(), reason="shared Radish data not present")
def test_corrected_csail_trajectory_scores_about_4cm():
    from sim.logs.carmen import import_log
    rel = read_relations(RADISH / "mit-csail.relations")
    log = import_log(RADISH / "csail.robotlaser1.log")   # corrected poses, 686 scans
    exact = relations_error(log.scan_t, log.odom_pose, rel, lookup="exact")
    # README: 129 relations, 0.0386 +- 0.0317 m, 0.374 +- 0.316 deg
    assert exact["n_used"] == 129
    assert exact["abs_trans_mean"] == pytest.approx(0.0386, abs=5e-4)
    assert exact["abs_trans_std"] == pytest.approx(0.0317, abs=5e-4)
    assert exact["abs_rot_deg_mean"] == pytest.approx(0.374, abs=5e-3)
    interp = relations_error(log.scan_t, log.odom_pose, rel)
    assert interp["n_used"] == 1172
    assert 0.03 < interp["abs_trans_mean"] < 0.05


@pytest.mark.skipif(not RADISH.is_dir(), reason="shared Radish data not present")
def test_raw_csail_odometry_baseline():
    from sim.logs.carmen import import_log
    rel = read_relations(RADISH / "mit-csail.relations")
    log = import_log(RADISH / "csail.corrected.gfs")
    res = relations_error(log.odom_t, log.odom_pose, rel)
    # README: 1.7057 +- 5.3192 m over all 1172; 0.0471 short, 15.234 long
    assert res["n_used"] == 1172
    assert res["abs_trans_mean"] == pytest.approx(1.7057, abs=1e-3)
    assert res["abs_trans_std"] == pytest.approx(5.3192, abs=1e-3)
    assert res["short"]["abs_trans_mean"] == pytest.approx(0.0471, abs=5e-4)
    assert res["long"]["n"] == 128
    assert res["long"]["abs_trans_mean"] == pytest.approx(15.234, abs=1e-2)


def test_written_relations_read_back(tmp_path):
    rng = np.random.default_rng(3)
    rel = Relations(np.arange(5) + 1e9, np.arange(5) + 1e9 + 0.5, rng.normal(0, 1, (5, 3)))
    write_relations(tmp_path / "r.relations", rel)
    back = read_relations(tmp_path / "r.relations")
    assert np.allclose(back.t1, rel.t1, atol=1e-6) and np.allclose(back.t2, rel.t2, atol=1e-6)
    assert np.allclose(back.delta, rel.delta, rtol=1e-8)
