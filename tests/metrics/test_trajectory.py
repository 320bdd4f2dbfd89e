"""ATE and RPE on hand-made trajectories."""
import numpy as np
import pytest

from metrics.trajectory import rigid_fit_2d, trajectory_error
from slam.pose import compose, transform_points
from worlds.yamlio import InputError


def square_path(n=400, side=2.0):
    """A closed 2 m square driven at constant speed, yaw along the path; t (n,), poses (n, 3)."""
    s = np.linspace(0.0, 4 * side, n, endpoint=False)
    k = (s // side).astype(int)
    u = s - k * side
    corners = np.array([[0, 0], [side, 0], [side, side], [0, side]], float)
    dirs = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]], float)
    xy = corners[k] + u[:, None] * dirs[k]
    yaw = np.arctan2(dirs[k, 1], dirs[k, 0])
    return s / 0.2, np.column_stack([xy, yaw])


def test_identical_is_zero():
    t, p = square_path()
    r = trajectory_error(t, p, t, p)
    assert r["ate_m"] == pytest.approx(0, abs=1e-12)
    assert r["ate_start_m"] == 0.0 and r["rpe_trans_m"] == pytest.approx(0, abs=1e-12)
    assert r["rpe_pairs"] > 300


def test_known_offset():
    t, p = square_path()
    est = p + np.array([0.3, -0.4, 0.0])
    r = trajectory_error(t, est, t, p)
    assert r["ate_start_m"] == pytest.approx(0.5)
    assert r["ate_m"] == pytest.approx(0.0, abs=1e-9)
    assert r["ate_align"]["x"] == pytest.approx(-0.3) and r["ate_align"]["y"] == pytest.approx(0.4)
    assert r["rpe_trans_m"] == pytest.approx(0.0, abs=1e-9)


def test_rigid_transform_leaves_ate_and_rpe_zero():
    t, p = square_path()
    est = compose(np.array([1.0, 2.0, 0.7]), p)
    r = trajectory_error(t, est, t, p)
    assert r["ate_m"] == pytest.approx(0.0, abs=1e-9)
    assert r["ate_start_m"] > 1.0
    assert r["rpe_trans_m"] == pytest.approx(0.0, abs=1e-9)
    assert r["rpe_rot_rad"] == pytest.approx(0.0, abs=1e-9)


def test_scale_error_gives_known_rpe():
    # the estimate goes 10 % too far: every 1 m segment is 0.1 m too long, straight sides
    t = np.linspace(0, 10, 1001)
    gt = np.column_stack([t * 0.5, np.zeros_like(t), np.zeros_like(t)])
    est = gt * np.array([1.1, 1.0, 1.0])
    r = trajectory_error(t, est, t, gt)
    assert r["rpe_trans_m"] == pytest.approx(0.1, rel=1e-6)
    assert r["rpe_rot_rad"] == 0.0


def test_truth_interpolated_at_estimate_times():
    t, p = square_path()
    te = (t[:-1] + t[1:]) / 2  # halfway between true samples, on straight parts exact
    pe = (p[:-1] + p[1:]) / 2
    straight = np.abs(np.diff(p[:, 2])) < 1e-9
    r = trajectory_error(te[straight], pe[straight], t, p)
    assert r["ate_start_m"] == pytest.approx(0.0, abs=1e-12)


def test_short_path_rpe_undefined_with_note():
    t = np.linspace(0, 1, 11)
    p = np.column_stack([t * 0.1, 0 * t, 0 * t])
    r = trajectory_error(t, p, t, p)
    assert np.isnan(r["rpe_trans_m"]) and "RPE undefined" in r["note"]


def test_no_overlap_in_time_is_an_error():
    t, p = square_path()
    with pytest.raises(InputError, match="time span"):
        trajectory_error(t + 1000.0, p, t, p)


def test_rigid_fit_recovers_random_transforms(rng):
    for _ in range(20):
        pose = np.array([*rng.normal(size=2) * 3, rng.uniform(-np.pi, np.pi)])
        src = rng.normal(size=(30, 2))
        fit = rigid_fit_2d(src, transform_points(pose, src))
        np.testing.assert_allclose(fit, pose, atol=1e-9)


@pytest.mark.parametrize("where, value, match", [
    ((5, 0), 1e308, "estimated trajectory: pose 5: x: 1e\\+308 is beyond"),
    ((7, 1), -3e6, "estimated trajectory: pose 7: y: -3e\\+06 is beyond"),
    ((2, 2), np.nan, "estimated trajectory: pose 2: non-finite yaw: nan"),
])
def test_huge_or_non_finite_poses_are_refused(where, value, match):
    """1e308 overflows the alignment's squares: an error, not an ATE of inf."""
    t, p = square_path()
    bad = p.copy()
    bad[where] = value
    with pytest.raises(InputError, match=match):
        trajectory_error(t, bad, t, p)


def test_times_in_nanoseconds_are_refused():
    t, p = square_path()
    with pytest.raises(InputError, match="true trajectory: pose 0: t: 1.7e\\+18 is beyond"):
        trajectory_error(t, p, t + 1.7e18, p)
