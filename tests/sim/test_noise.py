import numpy as np
import pytest

from sim.noise import LidarNoise, NoiseProfile, load_profile, profile_names
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
    assert r.lidar is None          # the recording lidar's own datasheet
    # MPU-9250: 0.01 deg/s/sqrt(Hz) and 300 micro-g/sqrt(Hz); sigma = density * sqrt(rate)
    assert r.imu.gyro.sigma(100.0) == pytest.approx(np.radians(0.01) * 10, rel=1e-3)
    assert r.imu.accel.sigma(100.0) == pytest.approx(300e-6 * 9.80665 * 10, rel=1e-3)


def test_band_model_reads_each_band_and_the_last_past_them():
    n = LidarNoise(bands=((0.5, 0.015, 0.0), (3.5, 0.0, 0.05)))
    np.testing.assert_allclose(n.sigma([0.2, 0.49, 0.5, 2.0, 5.0]),
                               [0.0075, 0.0075, 0.0125, 0.05, 0.125])
    # the near/far form is the same two bands
    old = LidarNoise(near_accuracy=0.015, far_accuracy_ratio=0.05, split=0.5)
    r = np.linspace(0.0, 10.0, 1001)
    assert np.array_equal(old.sigma(r), n.sigma(r))
    utm = LidarNoise(stddev=0.001, bands=((10.0, 0.03, 0.0), (30.0, 0.05, 0.0)))
    np.testing.assert_allclose(utm.sigma([1.0, 20.0]), np.hypot(0.001, [0.015, 0.025]))


@pytest.mark.parametrize("bands, match", [
    ([[1.0, 0.01, 0.0], [0.5, 0.02, 0.0]], r"bands\[1\]: up_to 0.5 is not above"),
    ([[1.0, -0.01, 0.0]], r"bands\[0\]: expected \[up_to, accuracy, ratio\]"),
    ([[1.0, 0.01]], r"bands\[0\]: expected 3 values"),
    ([[float(i), 0.01, 0.0] for i in range(1, 11)], r"at most 8 range bands"),
])
def test_bad_bands_are_one_line_errors(tmp_path, bands, match):
    p = tmp_path / "bad.yaml"
    p.write_text(f"lidar: {{bands: {bands}}}\n")
    with pytest.raises(InputError, match=match):
        load_profile(p)


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
