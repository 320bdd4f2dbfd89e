import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely

from sim import RecordConfig, SIM_VERSION, load_record_config, record, recording_problem, write_log
from sim.odometry import DRIFT_RANGE_REALISTIC
from worlds.model import ROBOT_RADIUS
from worlds.yamlio import InputError
from tests.sim.worlds_fixtures import square_room, walled_room

ROOT = Path(__file__).resolve().parents[2]
ROOM_ROUTE = [[3.0, 2.0], [3.0, 3.0], [1.0, 3.0]]


def _load(name):
    load_world = pytest.importorskip("worlds").load_world
    try:
        return load_world(name)
    except Exception as err:  # the worlds helper's YAMLs may not be there yet
        pytest.skip(f"world {name}: {err}")


def _shipped_worlds():
    try:
        from worlds import list_worlds
        return list_worlds()
    except ImportError:
        return []


@pytest.fixture(scope="module")
def room_log():
    return record(square_room(route=ROOM_ROUTE), seed=7, noise="realistic")


def test_log_layout_and_meta(room_log):
    log = room_log
    assert log.meta["ending"] == "end"
    assert log.scan_ranges.shape == (len(log.scan_t), 360)
    np.testing.assert_allclose(np.diff(log.scan_t), 0.2)
    np.testing.assert_allclose(log.scan_angles, np.radians(np.arange(360)))
    assert 1 / np.diff(log.odom_t).max() >= 30 - 1e-9
    assert 1 / np.diff(log.imu_t).max() >= 100 - 1e-9
    np.testing.assert_allclose(np.diff(log.gt_t), 0.005)
    # every revolution completes before the log ends
    assert log.scan_t[-1] + 0.2 <= log.gt_t[-1] + 1e-9
    lidar = log.meta["lidar"]
    assert lidar["offset"] == [-0.032, 0.0, 0.0]
    assert lidar["range_min"] == 0.12 and lidar["range_max"] == 3.5
    assert lidar["scan_time"] == 0.2 and lidar["time_increment"] == pytest.approx(0.2 / 360)
    assert log.meta["sim_version"] == SIM_VERSION and log.meta["seed"] == 7
    assert log.meta["noise"]["name"] == "realistic"
    assert log.meta["noise"]["lidar"]["bands"] == [[0.5, 0.015, 0.0], [3.5, 0.0, 0.05]]
    assert lidar["model"] == "LDS-01" and lidar["angle_increment"] == pytest.approx(np.radians(1))
    assert log.meta["start_pose"] == [1.0, 2.0, 0.0]
    assert log.meta["route_driven"] == 1.0 and log.meta["wall_coverage"] >= 0.95
    assert log.meta["route_length"] == pytest.approx(5.0)
    np.testing.assert_allclose(log.odom_pose[0], log.meta["start_pose"])
    np.testing.assert_allclose(log.gt_pose[0], log.meta["start_pose"])
    assert log.meta["robot"]["wheel_radius"] == 0.033
    fin = log.scan_ranges[np.isfinite(log.scan_ranges)]
    assert fin.min() >= 0.12 and fin.max() <= 3.5
    assert np.abs(log.gt_pose[:, 2]).max() <= np.pi


def test_same_seed_gives_identical_bytes(tmp_path, room_log):
    again = record(square_room(route=ROOM_ROUTE), seed=7, noise="realistic")
    write_log(room_log, tmp_path / "a.npz")
    write_log(again, tmp_path / "b.npz")
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()


def test_same_seed_identical_across_processes(tmp_path):
    world = _load("rectangle_s")
    write_log(record(world, seed=3), tmp_path / "here.npz")
    subprocess.run([sys.executable, "-m", "sim", "record", "--world", "rectangle_s", "--seed", "3",
                    "--out", str(tmp_path / "there.npz")], check=True, cwd=ROOT,
                   capture_output=True)
    assert (tmp_path / "here.npz").read_bytes() == (tmp_path / "there.npz").read_bytes()


def test_different_seed_gives_different_noise(room_log):
    other = record(square_room(route=ROOM_ROUTE), seed=8, noise="realistic")
    n = min(len(other.scan_t), len(room_log.scan_t))
    assert not np.array_equal(other.scan_ranges[:n], room_log.scan_ranges[:n])
    m = min(len(other.imu_t), len(room_log.imu_t))
    assert not np.allclose(other.imu_gyro[:m], room_log.imu_gyro[:m])
    assert not np.allclose(other.odom_pose[-1], room_log.odom_pose[-1])


def _gyro_error(log):
    """(K,) the log's gyro minus the true yaw rate at its samples (the rate as sim.imu takes
    it: central differences of the unwrapped true yaw at the physics steps)."""
    dt = float(np.diff(log.gt_t[:2])[0])
    rate = np.gradient(np.unwrap(log.gt_pose[:, 2]), dt)
    idx = np.rint(log.imu_t / dt).astype(int)
    return log.imu_gyro - rate[idx]


def test_same_seed_gives_the_same_gyro_bias_in_another_world():
    # docs/benchmark.md: a log's noise depends on its seed alone, so draw d of every world in a
    # suite has the same gyro bias and bias walk (the white noise left out: its draws follow
    # the walk's, whose count is the log's length)
    import dataclasses
    from sim.noise import load_profile
    real = load_profile("realistic")
    profile = dataclasses.replace(real, imu=dataclasses.replace(
        real.imu, gyro=dataclasses.replace(real.imu.gyro, density=0.0, stddev=0.0)))
    small = record(square_room(route=ROOM_ROUTE), seed=7, noise=profile)
    large = record(square_room(size=5.0, route=[[4.0, 2.0], [4.0, 4.0], [1.0, 4.0]]), seed=7,
                   noise=profile)
    a, b = _gyro_error(small), _gyro_error(large)
    assert len(a) != len(b)
    m = min(len(a), len(b))
    np.testing.assert_allclose(a[:m], b[:m], atol=1e-9)
    assert np.abs(a).max() > 1e-6        # a bias there is
    other = _gyro_error(record(square_room(route=ROOM_ROUTE), seed=8, noise=profile))
    k = min(len(other), m)
    assert not np.allclose(other[:k], a[:k], atol=1e-9)


def test_ideal_lidar_matches_the_geometry():
    world = square_room(route=ROOM_ROUTE)
    log = record(world, seed=0, noise="ideal", config={"lidar": {"motion_distortion": False}})
    # first scan: the robot stands at the start (1, 2, 0): hand-computed distances
    r = log.scan_ranges[0]
    assert r[0] == pytest.approx(3.95 - 0.968, abs=5e-4)
    assert r[90] == pytest.approx(1.95, abs=5e-4)
    assert r[180] == pytest.approx(0.918, abs=5e-4)


def test_ideal_scans_end_on_the_walls_from_each_beams_pose():
    world = square_room(route=ROOM_ROUTE)
    log = record(world, seed=0, noise="ideal")
    inc = log.meta["lidar"]["time_increment"]
    yaw = np.unwrap(log.gt_pose[:, 2])
    boundary = world.solid.boundary
    worst = 0.0
    for i in range(0, log.n_scans, 7):
        t = log.scan_t[i] + np.arange(360) * inc
        x, y, a = (np.interp(t, log.gt_t, c) for c in (log.gt_pose[:, 0], log.gt_pose[:, 1], yaw))
        lx, ly = x - 0.032 * np.cos(a), y - 0.032 * np.sin(a)
        r = log.scan_ranges[i]
        ok = np.isfinite(r)
        ends = np.c_[lx + r * np.cos(a + log.scan_angles), ly + r * np.sin(a + log.scan_angles)][ok]
        worst = max(worst, shapely.distance(boundary, shapely.points(ends)).max())
    assert worst < 0.0006          # 1 mm quantisation (+ interpolation of the pose)


def _odom_vs_truth(log):
    gx = np.interp(log.odom_t, log.gt_t, log.gt_pose[:, 0])
    gy = np.interp(log.odom_t, log.gt_t, log.gt_pose[:, 1])
    gyaw = np.interp(log.odom_t, log.gt_t, np.unwrap(log.gt_pose[:, 2]))
    pos = np.hypot(log.odom_pose[:, 0] - gx, log.odom_pose[:, 1] - gy)
    yaw = np.abs(np.mod(log.odom_pose[:, 2] - gyaw + np.pi, 2 * np.pi) - np.pi)
    return pos, yaw


def test_ideal_odometry_equals_the_true_path():
    log = record(_load("swirl_s"), seed=0, noise="ideal")
    assert log.meta["ending"] == "end" and log.meta["odometry_drift"]["distance"] > 10
    pos, yaw = _odom_vs_truth(log)
    tick_m = 2 * np.pi * 0.033 / 4096
    # encoder quantisation: one tick of difference between the wheels is 3.2e-4 rad
    assert yaw.max() <= 2 * tick_m / 0.160
    assert pos.max() < 10 * tick_m
    # and the ideal IMU's integrated yaw too
    gyaw = np.interp(log.imu_t, log.gt_t, np.unwrap(log.gt_pose[:, 2]))
    assert np.abs(np.mod(log.imu_yaw - gyaw + np.pi, 2 * np.pi) - np.pi).max() < 1e-6


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_realistic_odometry_drift_on_swirl_l(seed):
    log = record(_load("swirl_l"), seed=seed, noise="realistic")
    d = log.meta["odometry_drift"]
    print(f"swirl_l seed {seed}: drift {100 * d['segment_drift']:.2f} % per {d['segment']} m, "
          f"end error {d['end_error']:.2f} m over {d['distance']:.1f} m")
    assert log.meta["ending"] == "end"
    lo, hi = DRIFT_RANGE_REALISTIC
    assert lo <= d["segment_drift"] <= hi


def test_world_without_route_drives_the_planned_route():
    route_for = pytest.importorskip("worlds.route").route_for
    world = square_room(size=6.0, start=(1.0, 1.0, 0.0))       # no route in the world
    log = record(world, seed=0, noise="ideal")
    np.testing.assert_allclose(log.meta["route"], route_for(world))
    assert log.meta["ending"] == "end" and log.n_scans >= 5


def test_standing_still_gives_a_short_log():
    world = square_room(route=[[1.0, 2.0]])                     # the start itself
    log = record(world, seed=0, noise="ideal")
    assert log.meta["ending"] == "end" and log.gt_t[-1] == pytest.approx(1.0)
    assert log.n_scans == 5
    np.testing.assert_allclose(log.gt_pose, np.tile([1.0, 2.0, 0.0], (len(log.gt_t), 1)), atol=1e-12)


def test_closed_route_comes_back_to_its_start():
    # ends where it starts, first leg straight ahead (the case that once never started)
    world = square_room(start=(1.0, 1.0, 0.0), route=[[3.0, 1.0], [3.0, 3.0], [1.0, 3.0], [1.0, 1.0]])
    log = record(world, seed=3, noise="realistic")
    assert log.meta["ending"] == "end" and log.meta["route_driven"] == 1.0
    assert log.meta["odometry_drift"]["distance"] > 7.5
    assert np.hypot(*(log.gt_pose[-1, :2] - [1.0, 1.0])) < 0.1
    assert log.meta["wall_coverage"] >= 0.95 and recording_problem(log.meta) is None


@pytest.mark.parametrize("route", [
    [[2.0, 1.0], [3.0, 2.0], [2.0, 1.0], [1.5, 3.0]],           # revisits (2, 1)
    [[0.4, 1.0], [0.6, 3.0]],                                   # first waypoint behind
    [[1.0, 3.0], [3.0, 3.0]],                                   # beside, to the left
    [[1.0, 0.5], [3.0, 0.5]],                                   # beside, to the right
], ids=["revisit", "behind", "left", "right"])
def test_any_route_the_loader_accepts_is_driven_to_its_end(route):
    world = square_room(start=(1.0, 1.0, 0.0), route=route)
    log = record(world, seed=1, noise="realistic")
    assert log.meta["ending"] == "end" and log.meta["route_driven"] == 1.0
    assert np.hypot(*(log.gt_pose[-1, :2] - route[-1])) < 0.1


def test_recording_problem_names_the_reason():
    base = {"ending": "end", "route_length": 51.9, "route_driven": 1.0, "wall_coverage": 0.99}
    assert recording_problem(base) is None
    assert recording_problem({}) is None                       # a real log: nothing to judge
    stuck = dict(base, ending="stuck", route_driven=0.0)
    assert recording_problem(stuck) == "log ended stuck after 0.0 m of 51.9 m"
    late = dict(base, ending="time limit", route_driven=0.25)
    assert recording_problem(late) == "log hit the time limit after 13.0 m of 51.9 m"
    assert recording_problem(dict(base, ending="timeout")).startswith("log hit the time limit")
    assert recording_problem(dict(base, wall_coverage=0.9)) == \
        "log saw 90.0 % of the wall cells (< 95 %)"
    assert recording_problem(dict(base, wall_coverage=0.9), min_coverage=0.8) is None


def test_collision_shows_as_odometry_error():
    world = walled_room()
    log = record(world, seed=0, noise="ideal", config={"controller": {"stuck_timeout": 8.0}})
    assert log.meta["ending"] == "stuck"
    pts = shapely.points(log.gt_pose[:, :2])
    assert shapely.contains(world.free_space, pts).all()
    # the wall face is at x = 1.95: the body stops a radius before it, the wheels keep turning
    assert log.gt_pose[:, 0].max() < 1.95 - ROBOT_RADIUS + 0.005
    assert log.odom_pose[:, 0].max() > 2.5


def test_config_and_errors(tmp_path):
    assert load_record_config(None) == RecordConfig()
    p = tmp_path / "rec.yaml"
    p.write_text("lidar: {motion_distortion: false, beams: 180}\nodom_rate: 50\n")
    cfg = load_record_config(p)
    assert cfg.lidar.beams == 180 and not cfg.lidar.motion_distortion and cfg.odom_rate == 50
    p.write_text("lidar: {beam: 180}\n")
    with pytest.raises(InputError, match="lidar.beam: unknown key"):
        load_record_config(p)
    p.write_text("imu_rate: 333\n")
    with pytest.raises(InputError, match="whole number"):
        load_record_config(p)
    with pytest.raises(InputError, match="unknown noise profile"):
        record(square_room(route=ROOM_ROUTE), noise="noisy")


@pytest.mark.slow
@pytest.mark.parametrize("name", _shipped_worlds())
def test_robot_never_passes_through_a_wall(name):
    world = _load(name)
    log = record(world, seed=0, noise="realistic")
    pts = shapely.points(log.gt_pose[:, :2])
    assert shapely.contains(world.free_space, pts).all()
    assert shapely.distance(world.solid, pts).min() > ROBOT_RADIUS - 0.005
    assert log.meta["ending"] == "end"


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["office", "warehouse", "hall", "loop"])
def test_generated_worlds_record_completely(tmp_path, kind):
    from worlds import generate_yaml, load_world
    path = tmp_path / f"{kind}.yaml"
    path.write_text(generate_yaml(kind, 1))
    log = record(load_world(str(path)), seed=2, noise="realistic")
    assert log.meta["ending"] == "end" and recording_problem(log.meta) is None
    if kind == "loop":                                     # the route closes the loop
        assert np.hypot(*(log.gt_pose[-1, :2] - log.gt_pose[0, :2])) < 0.1
