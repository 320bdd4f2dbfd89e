"""sim.logs.npz: a plain npz (np.load reads it), entries of sensor noise stored, the rest
deflated, every array back bit for bit."""
import io
import json
import re
import tracemalloc
import zipfile

import numpy as np
import pytest

from sim.logs import SensorLog, read_log, write_log
from worlds.yamlio import InputError


def _log(n=3000, beams=90, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    pose = np.c_[np.cumsum(rng.normal(0, 1e-3, (n, 2)), axis=0), rng.uniform(-1, 1, n)]
    ranges = np.round(rng.uniform(0.2, 3.0, (n // 10, beams)), 3)
    ranges[:, ::7] = np.inf
    return SensorLog(scan_t=t[::10], scan_ranges=ranges,
                     scan_angles=np.arange(beams) * (2 * np.pi / beams),
                     odom_t=t, odom_pose=pose, odom_twist=np.zeros((n, 2)),
                     imu_t=t, imu_gyro=rng.standard_normal(n), imu_accel=rng.standard_normal((n, 2)),
                     imu_yaw=np.zeros(n), gt_t=t, gt_pose=pose, meta={"seed": 0})


def test_written_log_is_a_plain_npz_with_every_array_back_bit_for_bit(tmp_path):
    log = _log()
    write_log(log, tmp_path / "a.npz")
    with zipfile.ZipFile(tmp_path / "a.npz") as zf:
        kinds = {i.filename: i.compress_type for i in zf.infolist()}
    assert kinds["imu_gyro.npy"] == zipfile.ZIP_STORED        # white noise: stored
    assert kinds["imu_accel.npy"] == zipfile.ZIP_STORED
    assert kinds["scan_ranges.npy"] == zipfile.ZIP_DEFLATED   # quantised, with inf runs
    assert kinds["gt_t.npy"] == zipfile.ZIP_DEFLATED
    with np.load(tmp_path / "a.npz", allow_pickle=False) as npz:
        for name in ("scan_t", "scan_ranges", "imu_gyro", "imu_accel", "gt_pose"):
            assert npz[name].tobytes() == getattr(log, name).tobytes()
    back = read_log(tmp_path / "a.npz")
    assert back.imu_accel.tobytes() == log.imu_accel.tobytes()
    assert back.meta["seed"] == 0


def test_same_log_same_bytes(tmp_path):
    write_log(_log(), tmp_path / "a.npz")
    write_log(_log(), tmp_path / "b.npz")
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()


# --- hostile files: sizes are checked from the headers, before any array is read ---------

def _npy(arr) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.asarray(arr), allow_pickle=False)
    return buf.getvalue()


def _zip(path, members: dict[str, bytes]):
    """An .npz of the given raw members (name -> bytes), deflated at level 9 (zeros shrink
    a thousandfold, as in a zip bomb)."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=9) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return path


def _members(log, meta=None, **replace) -> dict[str, bytes]:
    """The members of `log` written raw, with some arrays (name -> array or bytes) replaced."""
    out = {"meta.npy": _npy(np.array(json.dumps(meta or {"format_version": 1})))}
    for name in ("scan_t", "scan_ranges", "scan_angles", "odom_t", "odom_pose", "odom_twist",
                 "imu_t", "imu_gyro", "imu_accel", "imu_yaw", "gt_t", "gt_pose"):
        v = replace.get(name, getattr(log, name))
        out[f"{name}.npy"] = v if isinstance(v, bytes) else _npy(v)
    return out


def _peak_bytes(fn):
    """(exception raised by fn(), peak bytes allocated meanwhile, numpy's included)."""
    tracemalloc.start()
    try:
        fn()
    except InputError as err:
        return err, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    raise AssertionError("no InputError")


def test_a_zip_bomb_member_is_refused_before_it_is_read(tmp_path):
    """16 MB of zeros in 16 kB of zip, as scan_t: refused from its header, naming the member,
    without allocating the array (the old reader took all of it, then found the shape bad)."""
    log = _log(n=300)
    bomb = _zip(tmp_path / "bomb.npz", _members(log, scan_t=np.zeros(2_000_000)))
    assert bomb.stat().st_size < 100_000
    err, peak = _peak_bytes(lambda: read_log(bomb))
    assert str(err) == f"{bomb}: scan_ranges has 30 rows but scan_t has 2000000"
    assert "\n" not in str(err) and peak < 4_000_000


def test_a_log_above_the_size_cap_is_refused_naming_the_member(tmp_path, monkeypatch):
    """Consistent shapes, but more bytes than MAX_LOG_BYTES (here cut to 1 MB): refused at
    the member that crosses the cap, before it is read."""
    import sim.logs.npz
    monkeypatch.setattr(sim.logs.npz, "MAX_LOG_BYTES", 1_000_000)
    log = _log(n=300)
    n = 20_000   # 20,000 scans of 90 beams: 14.4 MB as float64
    big = _zip(tmp_path / "big.npz", _members(log, scan_t=np.arange(n) * 0.01,
                                            scan_ranges=np.ones((n, 90))))
    err, peak = _peak_bytes(lambda: read_log(big))
    assert f"{big}: scan_ranges.npy: its (20000, 90) array brings the log to" in str(err)
    assert "more than the 1,000,000 a sensor log may hold" in str(err) and peak < 1_000_000
    with pytest.raises(InputError, match="more than the 1,000,000 a sensor log may hold"):
        write_log(SensorLog(scan_t=np.arange(n) * 0.01, scan_ranges=np.ones((n, 90)),
                            scan_angles=log.scan_angles), tmp_path / "w.npz")
    assert not (tmp_path / "w.npz").exists()


def test_a_bomb_below_the_size_cap_is_refused_by_its_inflation(tmp_path, monkeypatch):
    """Consistent shapes and sizes under MAX_LOG_BYTES, but zeros that inflate a thousandfold:
    refused from the zip directory before the array is read (a 1.5 GB bomb of 1.7 MB took
    1.5 GB before)."""
    import sim.logs.npz
    monkeypatch.setattr(sim.logs.npz, "_BOMB_MIN_BYTES", 1_000_000)
    log = _log(n=300)
    n = 20_000
    bomb = _zip(tmp_path / "bomb.npz", _members(log, scan_t=np.arange(n) * 0.01,
                                             scan_ranges=np.zeros((n, 90))))
    err, peak = _peak_bytes(lambda: read_log(bomb))
    assert re.fullmatch(rf"{re.escape(str(bomb))}: scan_ranges.npy: [\d,]+ compressed bytes "
                        r"inflate to 14,400,128, more than 200 times: a zip bomb, not sensor data",
                        str(err))
    assert peak < 1_000_000


def test_a_member_declaring_more_than_its_array_needs_is_refused(tmp_path):
    """A small header followed by megabytes: the zip's declared size (ZipInfo.file_size)
    must be what the header's array needs."""
    log = _log(n=300)
    padded = _npy(log.imu_yaw) + bytes(5_000_000)
    f = _zip(tmp_path / "padded.npz", _members(log, imu_yaw=padded))
    with pytest.raises(InputError, match=re.escape(
            f"{f}: imu_yaw.npy: declares 5,002,528 bytes uncompressed, its (300,) float64 "
            "array needs 2,528")):
        read_log(f)


def test_pickles_and_text_arrays_are_refused(tmp_path):
    log = _log(n=300)
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.array([{"a": 1}] * 3, dtype=object), allow_pickle=True)
    f = _zip(tmp_path / "pickle.npz", _members(log, gt_t=buf.getvalue()))
    with pytest.raises(InputError, match="gt_t.npy: holds Python objects"):
        read_log(f)
    f = _zip(tmp_path / "text.npz", _members(log, gt_t=np.array(["a", "b"])))
    with pytest.raises(InputError, match="gt_t.npy: expected numbers, got dtype <U1"):
        read_log(f)


@pytest.mark.parametrize("depth", [150, 100_000])
def test_deeply_nested_meta_is_one_line(tmp_path, depth):
    """JSON nested 100,000 deep raised RecursionError; 150 deep passed and waited for the
    first recursive reader."""
    log = _log(n=300)
    members = _members(log)
    members["meta.npy"] = _npy(np.array('{"format_version": 1, "x": ' + "[" * depth
                                        + "]" * depth + "}"))
    f = _zip(tmp_path / "deep.npz", members)
    with pytest.raises(InputError) as err:
        read_log(f)
    assert str(err.value) == f"{f}: meta: JSON nested deeper than 100 levels"


def test_meta_that_is_not_one_string(tmp_path):
    log = _log(n=300)
    members = _members(log)
    members["meta.npy"] = _npy(np.zeros(0))
    f = _zip(tmp_path / "meta.npz", members)
    with pytest.raises(InputError, match=re.escape(
            f"{f}: meta: expected one JSON string, got a (0,) float64 array")):
        read_log(f)


def test_logs_in_the_cache_pass_the_size_checks():
    """The real logs this machine recorded (if any) read as before: the caps are far above."""
    import glob
    import os
    base = os.environ.get("SLAM_BENCH_CACHE") or os.path.expanduser("~/.cache/slam-bench/logs")
    for f in sorted(glob.glob(os.path.join(base, "*.npz")))[:5]:
        assert read_log(f).n_scans > 0


def test_the_writer_refuses_meta_its_reader_refuses(tmp_path):
    deep = {"x": []}
    inner = deep["x"]
    for _ in range(120):
        inner.append([])
        inner = inner[0]
    with pytest.raises(InputError, match="meta: JSON nested deeper than 100 levels"):
        write_log(SensorLog(scan_t=np.zeros(0), scan_ranges=np.zeros((0, 0)),
                            scan_angles=np.zeros(0), meta=deep), tmp_path / "deep.npz")
    with pytest.raises(InputError, match="meta: 1,000,0[0-9]{2} characters, more than the "
                                         "1,000,000 a log's meta may have"):
        write_log(SensorLog(scan_t=np.zeros(0), scan_ranges=np.zeros((0, 0)),
                            scan_angles=np.zeros(0), meta={"x": "a" * 1_000_000}),
                  tmp_path / "long.npz")
    assert not list(tmp_path.iterdir())
