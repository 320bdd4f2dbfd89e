"""sim.log's .npz: a plain npz (np.load reads it), entries of sensor noise stored, the rest
deflated, every array back bit for bit."""
import zipfile

import numpy as np

from sim.log import SensorLog, read_log, write_log


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
