import numpy as np
import pytest

from sim.noise import NoiseProfile, load_profile, profile_names
from worlds.yamlio import InputError


def test_shipped_profiles():
    assert set(profile_names()) >= {"ideal", "gazebo", "realistic"}
    ideal = load_profile("ideal")
    assert ideal.name == "ideal"
    assert ideal.lidar.drop_prob == 0 and ideal.wheels.slip_density == 0
    assert ideal.imu.gyro.sigma(100.0) == 0


def test_gazebo_numbers_from_the_xacro():
    g = load_profile("gazebo")
    assert g.lidar.stddev == 0.01
    assert g.imu.gyro.stddev == 2e-4 and g.imu.accel.stddev == 1.7e-2
    assert g.wheels.slip_density == 0 and g.wheels.radius_error == 0


def test_realistic_numbers_from_the_datasheets():
    r = load_profile("realistic")
    assert r.lidar.near_accuracy == 0.015 and r.lidar.far_accuracy_ratio == 0.05
    # MPU-9250: 0.01 deg/s/sqrt(Hz) and 300 micro-g/sqrt(Hz); sigma = density * sqrt(rate)
    assert r.imu.gyro.sigma(100.0) == pytest.approx(np.radians(0.01) * 10, rel=1e-3)
    assert r.imu.accel.sigma(100.0) == pytest.approx(300e-6 * 9.80665 * 10, rel=1e-3)
    assert 0 < r.lidar.drop_prob <= 0.05


def test_unknown_profile_name():
    with pytest.raises(InputError, match="unknown noise profile 'realistc'.*realistic"):
        load_profile("realistc")


def test_user_yaml(tmp_path):
    p = tmp_path / "mine.yaml"
    p.write_text("lidar: {stddev: 0.02}\nimu: {gyro: {density: 1.0e-4}}\n")
    prof = load_profile(str(p))
    assert prof.name == "mine" and prof.lidar.stddev == 0.02 and prof.imu.gyro.density == 1e-4
    assert prof.wheels.slip_density == 0


def test_wrong_key_in_yaml(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("lidar: {stdev: 0.02}\n")
    with pytest.raises(InputError, match=r"bad.yaml: lidar.stdev: unknown key \(did you mean 'stddev'"):
        load_profile(p.as_posix())


def test_bad_values_in_yaml(tmp_path):
    p = tmp_path / "neg.yaml"
    p.write_text("lidar: {drop_prob: 1.5}\n")
    with pytest.raises(InputError, match="neg.yaml.*drop_prob"):
        load_profile(str(p))
    p.write_text("wheels: {slip_density: fast}\n")
    with pytest.raises(InputError, match="wheels.slip_density: expected a number"):
        load_profile(str(p))
    with pytest.raises(InputError, match="file not found"):
        load_profile(str(tmp_path / "missing.yaml"))


def test_profile_object_passes_through():
    p = NoiseProfile(name="x")
    assert load_profile(p) is p
