"""CARMEN and GMapping .gfs readers: real excerpts (tests/data) and hand-made lines."""
from __future__ import annotations

import gzip
import shutil
from pathlib import Path

import numpy as np
import pytest

from sim.logs import read_log, write_log
from sim.logs.carmen import default_angles, detect_format, import_log
from worlds.yamlio import InputError

DATA = Path(__file__).resolve().parents[2] / "data"
RADISH = Path(__file__).resolve().parents[4] / "shared" / "data" / "radish"


def _flaser(t: float, ranges, laser=(1.0, 2.0, 0.5), odom=(1.0, 2.0, 0.5)) -> str:
    vals = " ".join(f"{r:g}" for r in ranges)
    return (f"FLASER {len(ranges)} {vals} {' '.join(map(str, laser))} {' '.join(map(str, odom))} "
            f"{t:.6f} host {t - 100:.6f}")


def _write(tmp_path: Path, name: str, lines: list[str]) -> Path:
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


# --- real excerpts -----------------------------------------------------------------------------

def test_fr079_flaser_excerpt_raw_odometry_and_laser_offset():
    log = import_log(DATA / "carmen_fr079_head.log")
    assert log.meta["format"] == "carmen"
    assert log.n_scans == 4
    assert log.scan_ranges.shape == (4, 360)
    np.testing.assert_allclose(np.rad2deg(log.scan_angles[[0, 1, -1]]), [-90.0, -89.5, 89.5])
    # the FLASER laser pose lies 0.04 m behind the odometry pose (PARAM robot_frontlaser_offset)
    np.testing.assert_allclose(log.lidar_offset, [-0.04, 0.0, 0.0], atol=1e-5)
    assert log.meta["params"]["robot_frontlaser_offset"] == "-0.04"
    assert log.meta["odometry_kind"] == "raw"
    assert not log.has_ground_truth and log.meta["start_pose"] is None
    # ipc timestamps (robot clock, about 1211.5 s), not the logger's (about 0 s)
    assert 1211.0 < log.scan_t[0] < 1213.0
    # odometry = the FLASER robot poses, one per scan
    np.testing.assert_array_equal(log.odom_t, log.scan_t)
    first = (DATA / "carmen_fr079_head.log").read_text().split("\nFLASER ")[1].split()
    n = int(first[0])
    np.testing.assert_allclose(log.odom_pose[0], [float(v) for v in first[1 + n + 3:1 + n + 6]])
    # 81.91 marks no return
    raw = np.array([float(v) for v in first[1:1 + n]])
    assert np.all(np.isinf(log.scan_ranges[0][raw > 81.8]))
    np.testing.assert_allclose(log.scan_ranges[0][raw < 81.8], raw[raw < 81.8])


def test_gzip_is_detected_from_content(tmp_path):
    src = DATA / "carmen_fr079_head.log"
    dst = tmp_path / "fr079.clf"  # no .gz suffix on purpose
    with open(src, "rb") as fin, gzip.open(dst, "wb") as fout:
        shutil.copyfileobj(fin, fout)
    a, b = import_log(src), import_log(dst)
    np.testing.assert_array_equal(a.scan_ranges, b.scan_ranges)
    np.testing.assert_array_equal(a.odom_pose, b.odom_pose)


def test_robotlaser1_excerpt_angles_from_message():
    log = import_log(DATA / "carmen_csail_robotlaser1.log")
    assert log.n_scans == 3 and log.scan_ranges.shape[1] == 361
    assert log.meta["lidar"]["angles_from"] == "message"
    assert log.scan_angles[0] == pytest.approx(-1.570796)
    assert np.diff(log.scan_angles) == pytest.approx(0.008727)
    assert log.range_max == pytest.approx(80.0)
    assert np.all(np.isinf(log.scan_ranges[np.isinf(log.scan_ranges)]))
    assert np.nanmax(log.scan_ranges[np.isfinite(log.scan_ranges)]) < 80.0
    # tv = rv = 0 and laser pose = robot pose on every line: a corrected log
    assert log.meta["odometry_kind"] == "corrected"
    assert log.scan_t[0] == pytest.approx(1134864642.914187, abs=1e-6)


def test_gfs_excerpt_odometry_from_odom_lines():
    path = DATA / "csail_excerpt.gfs"
    log = import_log(path)
    assert log.meta["format"] == "gfs"
    assert log.n_scans == 3 and log.scan_ranges.shape[1] == 361
    np.testing.assert_allclose(np.rad2deg(log.scan_angles[[0, -1]]), [-90.0, 90.0])
    text = path.read_text().splitlines()
    odom = [ln.split() for ln in text if ln.startswith("ODOM ")]
    assert len(log.odom_t) == len(odom)
    np.testing.assert_allclose(log.odom_pose[-1], [float(v) for v in odom[-1][1:4]])
    np.testing.assert_allclose(log.odom_t[-1], float(odom[-1][4]))
    # every scan time is also an odometry time in this log
    assert np.all(np.isin(np.round(log.scan_t, 6), np.round(log.odom_t, 6)))
    assert log.meta["odometry_kind"] == "raw"
    assert log.range_max == pytest.approx(80.0)  # PARAM maxrange
    assert np.isinf(log.scan_ranges[0, 0])  # 81.91 = no return


def test_round_trip_through_npz(tmp_path):
    log = import_log(DATA / "csail_excerpt.gfs")
    write_log(log, tmp_path / "csail.npz")
    back = read_log(tmp_path / "csail.npz")
    np.testing.assert_array_equal(back.scan_ranges, log.scan_ranges)
    np.testing.assert_array_equal(back.odom_pose, log.odom_pose)
    assert back.meta["odometry_kind"] == "raw"


def test_format_detection_and_forcing(tmp_path):
    assert detect_format(["PARAM x 1", "ODOM 1 2 3 4"]) is None
    assert detect_format(["LASER_READING 1 2 0 0 0 5"]) == "gfs"
    assert detect_format([_flaser(1.0, [1.0] * 180)]) == "carmen"
    with pytest.raises(InputError, match="unknown log format"):
        import_log(DATA / "csail_excerpt.gfs", fmt="rosbag")
    # forcing CARMEN on a .gfs: its 5-field ODOM lines are malformed CARMEN ODOM lines
    with pytest.raises(InputError, match="line 36: ODOM: expected 10 fields"):
        import_log(DATA / "csail_excerpt.gfs", fmt="carmen")


# --- hand-made lines ---------------------------------------------------------------------------

def test_default_angles():
    np.testing.assert_allclose(np.rad2deg(default_angles(180))[[0, -1]], [-90, 89])
    np.testing.assert_allclose(np.rad2deg(default_angles(181))[[0, -1]], [-90, 90])
    np.testing.assert_allclose(np.rad2deg(default_angles(361))[[0, 1]], [-90, -89.5])
    np.testing.assert_allclose(np.rad2deg(np.diff(default_angles(90))), 2.0)


def test_no_return_marker_and_values(tmp_path):
    r = np.full(180, 5.0)
    r[10] = 50.0   # the sensor maximum (ACES style)
    r[11] = 49.95  # within the marker spread
    r[12] = 12.5
    p = _write(tmp_path, "a.log", [_flaser(10.0, r), _flaser(10.2, np.full(180, 3.0)),
                                    "ODOM 1 2 3 0 0 0 10.1 host 0.1", "NEFF 3.2"])
    log = import_log(p)
    assert np.isinf(log.scan_ranges[0, 10]) and np.isinf(log.scan_ranges[0, 11])
    assert log.scan_ranges[0, 12] == 12.5 and log.scan_ranges[1, 0] == 3.0
    assert log.meta["odometry_kind"] == "corrected"  # GMapping's NEFF lines
    assert log.meta["messages"] == {"FLASER": 2, "NEFF": 1, "ODOM": 1}


def test_no_return_marker_below_stray_maxima(tmp_path):
    # acapulco: 9264 readings of 51.15, 3020 of 51.14, one stray 51.25 above the marker
    r = np.full(181, 7.0)
    r[:40], r[40:50], r[50], r[51] = 51.15, 51.14, 51.25, 50.9
    log = import_log(_write(tmp_path, "m.log", [_flaser(1.0, r), _flaser(2.0, np.full(181, 7.0))]))
    assert np.all(np.isinf(log.scan_ranges[0, :51]))
    assert log.scan_ranges[0, 51] == pytest.approx(50.9)
    assert log.meta["lidar"]["range_max"] == pytest.approx(51.15)


@pytest.mark.parametrize("bad, pattern", [
    (lambda line: line.rsplit(" ", 1)[0], "line 2: FLASER: expected 191 fields"),
    (lambda line: line.replace(" 5 ", " five ", 1), "line 2: .*not a number: 'five'"),
    (lambda line: "FLASER x " + line.split(" ", 2)[2], "line 2: FLASER num_readings: expected an integer"),
    (lambda line: line.replace(" 5 ", " nan ", 1), "line 2: non-finite"),
])
def test_malformed_line_names_file_and_line(tmp_path, bad, pattern):
    good = _flaser(1.0, np.full(180, 5.0))
    p = _write(tmp_path, "bad.log", ["# comment", bad(_flaser(2.0, np.full(180, 5.0))), good])
    with pytest.raises(InputError, match=pattern) as info:
        import_log(p)
    assert "bad.log" in str(info.value)


def test_malformed_odom_and_gfs_lines(tmp_path):
    p = _write(tmp_path, "o.log", [_flaser(1.0, np.full(180, 5.0)), "ODOM 1 2 3 0 0 0 1.0 host"])
    with pytest.raises(InputError, match="line 2: ODOM: expected 10 fields"):
        import_log(p)
    g = _write(tmp_path, "g.gfs", ["ODOM 1 2 3 4", "LASER_READING 3 1 2 3 0 0 0", "ODO_UPDATE 0 5"])
    with pytest.raises(InputError, match="line 2: LASER_READING: expected 9 fields"):
        import_log(g)


def test_no_scans_and_empty_file(tmp_path):
    p = _write(tmp_path, "odom_only.log", ["ODOM 1 2 3 0 0 0 1.0 host 1.0"])
    with pytest.raises(InputError, match="no laser scans"):
        import_log(p)
    e = _write(tmp_path, "empty.log", ["# nothing"])
    with pytest.raises(InputError, match="no laser scan or odometry message"):
        import_log(e)
    with pytest.raises(InputError, match="file not found"):
        import_log(tmp_path / "missing.log")


def test_beam_count_change_is_an_error(tmp_path):
    p = _write(tmp_path, "mix.log", [_flaser(1.0, np.full(180, 5.0)), _flaser(2.0, np.full(360, 5.0))])
    with pytest.raises(InputError, match="line 2: scan has 360 beams"):
        import_log(p)


def test_unusable_timestamps_rejected_single_glitch_dropped(tmp_path):
    r = np.full(180, 5.0)
    same = [_flaser(1.13486e9, r) for _ in range(5)]  # %g-printed times: all equal
    with pytest.raises(InputError, match="timestamps are unusable"):
        import_log(_write(tmp_path, "g.log", same))
    # one scan stamped 1.1 s late among 200 (as in the Intel log): dropped, noted in meta
    times = list(np.arange(200) * 0.5)
    times[100] = times[100] + 1.1
    log = import_log(_write(tmp_path, "i.log", [_flaser(t, r) for t in times]))
    assert log.n_scans == 199 and np.all(np.diff(log.scan_t) > 0)
    assert log.meta["dropped_scan_lines"] == [101]


def test_odom_lines_out_of_order_dropped(tmp_path):
    g = _write(tmp_path, "o.gfs", ["ODOM 0 0 0 1.0", "ODOM 1 0 0 2.0", "ODOM 9 9 0 0.0",
                                   "ODOM 2 0 0 3.0", "LASER_READING 3 1 2 3 0 0 0 1.5"])
    log = import_log(g)
    np.testing.assert_array_equal(log.odom_t, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(log.odom_twist[0], [1.0, 0.0])  # derived: 1 m in 1 s


# --- every shared log whose timestamps are usable -----------------------------------------------

USABLE = ["csail.corrected.gfs", "csail.robotlaser1.log", "intel.gfs.log", "fr079.clf.head.txt",
          "corrected/aces-corrected.log.gz", "corrected/intel-corrected.log.gz",
          "corrected/freiburg-079-corrected.log.gz", "corrected/freiburg-101-corrected.log.gz",
          "corrected/acapulco-corrected.log.gz", "corrected/edmonton-corrected.log.gz",
          "corrected/fhw-corrected.log.gz", "corrected/seattle-corrected.log.gz"]
UNUSABLE = ["csail.corrected.log", "corrected/orebro-corrected.log.gz",
            "corrected/freiburg-campus-corrected.log.gz", "corrected/belgioioso-corrected.log.gz",
            "corrected/infinite-corridor-corrected.log.gz", "corrected/csail-corrected.log.gz"]


@pytest.mark.slow
@pytest.mark.skipif(not RADISH.is_dir(), reason="shared Radish data not present")
def test_every_usable_radish_log_imports():
    for name in USABLE:
        log = import_log(RADISH / name)
        assert log.n_scans > 0 and np.all(np.diff(log.scan_t) > 0), name
        assert log.has_odometry, name
    for name in UNUSABLE:
        with pytest.raises(InputError, match="timestamps are unusable"):
            import_log(RADISH / name)
