"""Scan preprocessing: range limits, offset, smoothing, de-skew."""
import numpy as np
import pytest

from slam.base import ImuWindow, OdomDelta, Scan
from slam._kernels.beams import _median_step, motion_during, scan_points, scan_points_ref
from slam._kernels.censor import censoring_shortfall
from slam._kernels.smooth import smooth_ranges
from slam.preprocess import (PreprocessConfig, censoring_corrected, preprocess, sweep_twist, twist_from_poses,
                             yaw_rate_from_imu)
from slam.pose import compose
from slam.range_noise import DEFAULT_RANGE_NOISE

ANGLES = np.linspace(0, 2 * np.pi, 8, endpoint=False)


def _scan(ranges, offset=(0.0, 0.0, 0.0), t_inc=0.0, angles=ANGLES):
    return Scan(0.0, np.asarray(ranges, float), angles, 0.12, 3.5, np.asarray(offset, float), t_inc)


def test_range_limits_and_no_return():
    s = _scan([1.0, np.inf, np.nan, 0.05, 3.5, 2.0, -1.0, 0.5])
    out = preprocess(s, PreprocessConfig())
    assert len(out.points) == 3 and len(out.misses) == 0
    out = preprocess(s, PreprocessConfig(free_range=3.0))
    assert len(out.misses) == 2  # the inf and the 3.5 (= range_max) beam
    np.testing.assert_allclose(np.hypot(*out.misses.T), 3.0)


def test_lidar_offset_applied():
    out = preprocess(_scan([1.0] + [np.inf] * 7, offset=(-0.032, 0.0, 0.0)))
    np.testing.assert_allclose(out.points, [[0.968, 0.0]])
    np.testing.assert_allclose(out.origin, [-0.032, 0.0])
    out = preprocess(_scan([1.0] + [np.inf] * 7, offset=(0.1, 0.2, np.pi / 2)))
    np.testing.assert_allclose(out.points, [[0.1, 1.2]], atol=1e-12)


def test_config_rejects_bad_values():
    with pytest.raises(ValueError):
        PreprocessConfig(smooth_beams=-1)
    with pytest.raises(ValueError):
        PreprocessConfig(range_max=-1.0)


def test_motion_during_is_the_se2_exponential():
    tw = np.array([0.3, 0.0, 1.2])
    taus = np.array([0.05, 0.1])
    m = motion_during(tw, taus)
    step = motion_during(tw, [0.05])[0]
    np.testing.assert_allclose(compose(step, step), m[1], atol=1e-12)
    np.testing.assert_allclose(twist_from_poses(np.zeros(3), m[1], 0.1), [m[1][0] / 0.1, m[1][1] / 0.1, 0.12 / 0.1], atol=1e-12)


def test_deskew_recovers_a_static_wall_seen_while_turning():
    # robot turning at w while the beams sweep; each beam hits the point P_j fixed in the world
    beams = 90
    angles = np.linspace(0, 2 * np.pi, beams, endpoint=False)
    t_inc = 0.2 / beams
    tw = np.array([0.2, 0.0, 1.0])
    poses = motion_during(tw, np.arange(beams) * t_inc)   # beam poses relative to the pose at t0
    off = np.array([-0.032, 0.0, 0.0])
    # true world points at 2 m from the lidar along each beam at its own time
    lid = compose(poses, np.broadcast_to(off, poses.shape))
    world = np.stack([lid[:, 0] + 2 * np.cos(lid[:, 2] + angles), lid[:, 1] + 2 * np.sin(lid[:, 2] + angles)], 1)
    scan = _scan(np.full(beams, 2.0), offset=off, t_inc=t_inc, angles=angles)
    out = preprocess(scan, PreprocessConfig(), twist=tw)
    np.testing.assert_allclose(out.points, world, atol=1e-9)
    raw = preprocess(scan, PreprocessConfig(deskew=False), twist=tw)
    assert np.abs(raw.points - world).max() > 0.1


def test_smoothing_keeps_a_flat_wall_flat_and_reduces_noise(rng):
    beams = 360
    angles = np.linspace(0, 2 * np.pi, beams, endpoint=False)
    # a wall x = 1 seen by beams within 60 degrees of the x axis; the rest return nothing
    with np.errstate(divide="ignore"):
        r = np.where(np.cos(angles) > 0.5, 1.0 / np.cos(angles), np.inf)
    noisy = r * (1 + 0.025 * rng.standard_normal(beams))
    scan = _scan(noisy, angles=angles)
    raw = preprocess(scan, PreprocessConfig()).points
    smooth = preprocess(scan, PreprocessConfig(smooth_beams=4)).points
    assert len(raw) == len(smooth) == int(np.sum(np.cos(angles) > 0.5))
    assert np.std(smooth[:, 0] - 1.0) < 0.5 * np.std(raw[:, 0] - 1.0)
    exact = preprocess(_scan(np.where(np.isfinite(r), r, np.inf), angles=angles), PreprocessConfig(smooth_beams=4)).points
    np.testing.assert_allclose(exact[:, 0], 1.0, atol=1e-9)  # averaging points of a line stays on it


def test_smoothing_keeps_depth_jumps():
    r = np.r_[np.full(10, 1.0), np.full(10, 2.0)]
    along, across = smooth_ranges(r, np.ones(20, bool), 3, 0.1, 0.01, False)
    assert np.all(np.abs(along[:8] - 1.0) < 0.01) and np.all(np.abs(along[12:] - 2.0) < 0.01)


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(4))
def test_scan_points_matches_its_reference(seed):
    """Random revolutions with no returns, short and long readings and NaN; with and without
    smoothing, free space and de-skew (turning and straight)."""
    rng = np.random.default_rng(seed)
    n = 360
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ranges = rng.uniform(0.05, 4.0, n)
    ranges[rng.random(n) < 0.1] = np.inf
    ranges[rng.random(n) < 0.02] = np.nan
    offset = np.array([-0.03, 0.01, 0.05])
    for smooth, free, twist in [(0, 0.0, np.array([0.2, 0.0, 0.8])), (4, 1.0, np.zeros(3)),
                                (2, 5.0, np.array([0.1, 0.02, 0.0])), (4, 0.5, np.array([0.3, 0.0, -1.1]))]:
        args = (ranges, angles, offset, 0.12, 3.5, free, smooth, 0.1, twist, 2e-4, seed % 2 == 0)
        for got, want in zip(scan_points(*args), scan_points_ref(*args)):
            assert got.shape == want.shape
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", ["jitter", "ties", "equal", "shuffled"])
def test_median_step_is_numpys_median_of_the_steps(kind):
    rng = np.random.default_rng(7)
    for n in range(0, 41):
        steps = {"jitter": rng.normal(0.0175, 1e-4, n), "ties": rng.integers(0, 3, n) * 0.5,
                 "equal": np.full(n, 0.0175), "shuffled": rng.normal(0.0, 1.0, n)}[kind]
        angles = np.cumsum(steps) if kind != "shuffled" else steps
        want = float(np.median(np.diff(angles))) if n > 1 else 0.0
        assert _median_step(angles) == want


def _imu(sweep_gyro=()):
    z = np.zeros(0)
    return ImuWindow(z, z, np.zeros((0, 2)), z, np.asarray(sweep_gyro, float))


def test_sweep_twist_is_the_motion_measured_during_the_revolution():
    scan = _scan([1.0] * 8, t_inc=0.2 / 7)    # last beam 0.2 s after the first
    lagged = np.array([0.0, 0.0, -0.5])        # the motion before the scan: turning the other way
    odom = OdomDelta(np.array([1.0, 2.0, 0.0]), np.array([1.0, 2.0, 0.1]), np.array([1.02, 2.0, 0.1]))
    # translation and rotation from the odometry over the revolution
    np.testing.assert_allclose(sweep_twist(scan, odom, None, lagged), twist_from_poses(odom.pose, odom.sweep_end, 0.2))
    # the gyro's samples in the revolution turn it, the odometry moves it
    tw = sweep_twist(scan, odom, _imu([0.7, 0.9]), lagged)
    np.testing.assert_allclose(tw[2], 0.8)
    np.testing.assert_allclose(tw[:2], twist_from_poses(odom.pose, odom.sweep_end, 0.2)[:2])
    # gyro alone: the caller's translation, the gyro's rotation
    np.testing.assert_allclose(sweep_twist(scan, None, _imu([0.4]), np.array([0.1, 0.0, -0.5])), [0.1, 0.0, 0.4])
    np.testing.assert_allclose(sweep_twist(scan, None, _imu([0.4]), None), [0.0, 0.0, 0.4])


def test_sweep_twist_falls_back_when_the_revolution_was_not_measured():
    lagged = np.array([0.1, 0.0, 0.2])
    no_end = OdomDelta(np.zeros(3), np.zeros(3), None)
    timed = _scan([1.0] * 8, t_inc=0.2 / 7)
    assert sweep_twist(timed, no_end, _imu(), lagged) is lagged
    assert sweep_twist(timed, None, None, None) is None
    # a scan without beam timing has no revolution to measure
    untimed = _scan([1.0] * 8)
    odom = OdomDelta(np.zeros(3), np.zeros(3), np.array([0.1, 0.0, 0.0]))
    assert sweep_twist(untimed, odom, _imu([1.0]), lagged) is lagged


def test_yaw_rate_from_imu_integrates_by_timestamps():
    """A jerky turn read by a 100 Hz gyro whose timestamps are multiples of a 5 ms physics
    step, in 0.2 s windows (t0, t1] of a 5 Hz lidar: float edges give windows of 19, 20 and 21
    samples. Integrated by their timestamps the windows add up to the samples' integral over
    the whole turn, however the samples fell; the plain means of the windows do not."""
    imu_t = (np.arange(0, 801) * 0.005)[::2]              # every second 5 ms physics step
    imu_w = 0.2 + 0.7 * np.sin(2 * np.pi * imu_t / 0.45 + 0.3)
    edges = np.arange(21) / 5.0                           # scans at 5 Hz
    whole = float(np.sum(imu_w[1:] * np.diff(imu_t)))     # each rate held since the sample before
    counts, by_time, by_mean = [], 0.0, 0.0
    for t0, t1 in zip(edges[:-1], edges[1:]):
        m = (imu_t > t0) & (imu_t <= t1)
        win = ImuWindow(imu_t[m], imu_w[m], np.zeros((m.sum(), 2)), np.zeros(m.sum()))
        counts.append(int(m.sum()))
        by_time += yaw_rate_from_imu(win, t0, t1) * (t1 - t0)
        by_mean += float(np.mean(imu_w[m])) * (t1 - t0)
    assert {19, 21} <= set(counts)
    assert abs(by_time - whole) < 1e-3 * abs(whole)
    assert abs(by_mean - whole) > 10 * abs(by_time - whole)
    assert yaw_rate_from_imu(None, 0.0, 0.2) is None
    assert yaw_rate_from_imu(win, 0.2, 0.2) == pytest.approx(float(np.mean(win.gyro)))


def test_censoring_corrected_lengthens_the_hits_near_the_limit_by_the_scans_noise_model(rng):
    angles = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    d = np.where(np.arange(360) < 180, 1.5, 3.45)          # a near wall ahead, a far one behind
    r = d + rng.normal(0.0, 1.0, 360) * DEFAULT_RANGE_NOISE.sigma(d)
    r[r >= 3.5] = np.inf                                     # the lidar loses what lies beyond 3.5 m
    r[5] = np.nan
    scan = Scan(0.0, r, angles, 0.12, 3.5, np.zeros(3))
    out = censoring_corrected(scan)
    far = (d == 3.45) & np.isfinite(r)
    assert np.array_equal(out.ranges[~far], r[~far], equal_nan=True)
    lift = out.ranges[far] - r[far]
    sigma = DEFAULT_RANGE_NOISE.sigma(3.5)
    assert np.all(lift > 0) and 0.3 * sigma < lift.mean() < 1.0 * sigma
    assert abs(out.ranges[far].mean() - 3.45) < abs(r[far].mean() - 3.45)
    assert out.range_max == pytest.approx(3.5 + 2 * sigma)  # room for the lengthened hits
    assert preprocess(out, PreprocessConfig()).points.shape[0] == np.sum(r < 3.5)
    # a limit below the sensor's censors there: what lies beyond it is no return
    lower = censoring_corrected(scan, 3.0)
    assert np.all(np.isinf(lower.ranges[d == 3.45]))
    assert np.array_equal(lower.ranges[d == 1.5], r[d == 1.5], equal_nan=True)
    # a fan of beams (not a whole revolution) has no neighbour across its ends: its first beam,
    # alone, is corrected by its own range, the same beam of a revolution by its last beams'
    ends = np.full(20, np.inf)
    ends[0], ends[-4:] = 3.40, [3.42, 3.43, 3.41, 3.44]
    fan = censoring_corrected(Scan(0.0, ends, angles[:20], 0.12, 3.5, np.zeros(3)))
    ring = censoring_corrected(Scan(0.0, ends, np.linspace(0, 2 * np.pi, 20, endpoint=False), 0.12, 3.5,
                                    np.zeros(3)))
    assert fan.ranges[0] == pytest.approx(3.40 + censoring_shortfall(ends, 3.5, sigma, 4, False)[0])
    assert ring.ranges[0] == pytest.approx(3.40 + censoring_shortfall(ends, 3.5, sigma, 4, True)[0])
    assert ring.ranges[0] > fan.ranges[0] + 1e-4        # the neighbours' wall is farther
