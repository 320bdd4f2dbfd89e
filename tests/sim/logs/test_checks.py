"""Sensor logs are checked for their values at read time (sim.logs.checks): each bad value gets
one line naming the file, the array or field and the first bad index; writers and importers
refuse to produce such logs."""
import numpy as np
import pytest

from sim.logs import FORMAT_VERSION, read_log, write_log
from sim.logs.checks import MAX_SPEED_M_S
from slam.__main__ import main as slam_main
from tests.rawlog import raw_npz_bytes
from tests.slam.synthlog import box_room_segments, make_log
from worlds.yamlio import InputError


@pytest.fixture(scope="module")
def good():
    return make_log(box_room_segments(), np.array([[1.0, 1.0], [2.0, 1.0]]), seed=4)


def _arrays(log):
    names = ("scan_t", "scan_ranges", "scan_angles", "odom_t", "odom_pose", "odom_twist",
             "imu_t", "imu_gyro", "imu_accel", "imu_yaw", "gt_t", "gt_pose")
    return {n: np.array(getattr(log, n), dtype=np.float64) for n in names}


def _write_raw(path, arrays, meta):
    path.write_bytes(raw_npz_bytes(arrays, meta))
    return path


def _damaged(good, tmp_path, change):
    arrays, meta = _arrays(good), dict(good.meta, format_version=FORMAT_VERSION)
    change(arrays, meta)
    return _write_raw(tmp_path / "bad.npz", arrays, meta)


def _swap_scans(a, m):
    a["scan_t"][[5, 6]] = a["scan_t"][[6, 5]]


def _nan_odometry(a, m):
    a["odom_pose"][:] = np.nan


def _jump(a, m):
    a["gt_pose"][40, 0] += 1e5


CASES = [
    ("scans out of time order", _swap_scans, r"scan_t\[6\]: 1 s is not after scan_t\[5\] = 1.2 s"),
    ("all-NaN odometry", _nan_odometry, r"odom_pose\[0, 0\]: not finite"),
    ("a NaN scan time", lambda a, m: a["scan_t"].__setitem__(3, np.nan), r"scan_t\[3\]: not a finite time"),
    ("a NaN scan angle", lambda a, m: a["scan_angles"].__setitem__(7, np.nan), r"scan_angles\[7\]: not finite"),
    ("a NaN true pose", lambda a, m: a["gt_pose"].__setitem__((2, 1), np.nan), r"gt_pose\[2, 1\]: not finite"),
    ("a NaN range", lambda a, m: a["scan_ranges"].__setitem__((1, 9), np.nan), r"scan_ranges\[1, 9\]: NaN"),
    ("a negative range", lambda a, m: a["scan_ranges"].__setitem__((2, 3), -1.0), r"scan_ranges\[2, 3\]: negative"),
    ("angles not monotonic", lambda a, m: a["scan_angles"].__setitem__(10, a["scan_angles"][8]),
     r"scan_angles\[10\]: .*strictly increasing or decreasing"),
    ("a 100 km jump", _jump, rf"gt_pose\[40\]: jumps 1e\+05 m .*faster than {MAX_SPEED_M_S:g} m/s"),
    ("lidar null", lambda a, m: m.update(lidar=None), r"meta.lidar: expected a mapping, got None"),
    ("a string range", lambda a, m: m.update(lidar={**m["lidar"], "range_max": "far"}),
     r"meta.lidar.range_max: expected a number >= 0, got 'far'"),
    ("format_version 0", lambda a, m: m.update(format_version=0), r"meta.format_version: expected an integer >= 1, got 0"),
    ("format_version -3", lambda a, m: m.update(format_version=-3), r"meta.format_version: .* got -3"),
    ("format_version true", lambda a, m: m.update(format_version=True), r"meta.format_version: .* got True"),
]


@pytest.mark.parametrize("label, change, message", CASES, ids=[c[0] for c in CASES])
def test_bad_values_are_one_line_naming_the_array_and_index(good, tmp_path, label, change, message):
    path = _damaged(good, tmp_path, change)
    with pytest.raises(InputError, match=message) as err:
        read_log(path)
    assert str(err.value).startswith(str(path)) and "\n" not in str(err.value)


def test_meta_that_is_not_a_mapping(good, tmp_path):
    path = _write_raw(tmp_path / "list.npz", _arrays(good), [1, 2, 3])
    with pytest.raises(InputError, match="meta: expected a mapping, got list"):
        read_log(path)


def test_the_slam_cli_refuses_a_bad_log_in_one_line(good, tmp_path, capsys):
    """Scans out of time order ran through gn with exit 0 and a wrecked map before."""
    path = _damaged(good, tmp_path, _swap_scans)
    assert slam_main(["run", "--algo", "gn", "--log", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "scan_t[6]" in err[0]
    assert not (tmp_path / "o").exists()


def test_writer_refuses_what_the_reader_would_refuse(good, tmp_path):
    arrays = _arrays(good)
    arrays["odom_pose"][3, 1] = np.inf
    bad = type(good)(**arrays, meta=good.meta)
    with pytest.raises(InputError, match=r"odom_pose\[3, 1\]: not finite"):
        write_log(bad, tmp_path / "w.npz")
    assert not (tmp_path / "w.npz").exists()
    write_log(good, tmp_path / "ok.npz")
    assert read_log(tmp_path / "ok.npz").n_scans == good.n_scans
