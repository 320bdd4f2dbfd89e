"""TUM trajectory files: round trip and clear errors on bad lines."""
import re

import numpy as np
import pytest

from sim.logs.tum import read_tum, write_tum, yaw_from_quaternion
from worlds.yamlio import InputError


def test_round_trip(tmp_path, rng):
    t = np.cumsum(rng.uniform(0.05, 0.2, 50))
    poses = np.column_stack([rng.normal(size=(50, 2)), rng.uniform(-np.pi, np.pi, 50)])
    write_tum(tmp_path / "a.tum", t, poses)
    t2, p2 = read_tum(tmp_path / "a.tum")
    np.testing.assert_allclose(t2, t, atol=1e-9)
    np.testing.assert_allclose(p2[:, :2], poses[:, :2], atol=1e-7)
    np.testing.assert_allclose(np.angle(np.exp(1j * (p2[:, 2] - poses[:, 2]))), 0, atol=1e-9)


def test_yaw_from_quaternion_ignores_nothing_in_plane():
    assert yaw_from_quaternion(0, 0, np.sin(0.3), np.cos(0.3)) == pytest.approx(0.6)


def test_comments_and_unsorted_lines(tmp_path):
    f = tmp_path / "b.tum"
    f.write_text("# t x y z qx qy qz qw\n2 1 0 0 0 0 0 1\n\n1 0 0 0 0 0 0 1\n")
    t, p = read_tum(f)
    assert list(t) == [1.0, 2.0] and list(p[:, 0]) == [0.0, 1.0]


@pytest.mark.parametrize("text, match", [
    ("1 2 3\n", "line 1: expected 8 numbers"),
    ("1 0 0 0 0 0 0 1\n2 a 0 0 0 0 0 1\n", "line 2: not a number"),
    ("1 0 0 0 0 0 0 0\n", "zero quaternion"),
    ("# nothing\n", "no poses"),
    ("1 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n", "repeated timestamps"),
])
def test_bad_files(tmp_path, text, match):
    f = tmp_path / "bad.tum"
    f.write_text(text)
    with pytest.raises(InputError, match=match):
        read_tum(f)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_tum(tmp_path / "none.tum")


@pytest.mark.parametrize("line, match", [
    ("2 1e308 0 0 0 0 0 1", "line 2: x: 1e+308 is beyond"),
    ("2 0 -2e6 0 0 0 0 1", "line 2: y: -2e+06 is beyond"),
    ("2 0 0 0 0 0 1e308 1", "line 2: qz: 1e+308 is beyond"),
    ("1.7e18 0 0 0 0 0 0 1", "line 2: t: 1.7e+18 is beyond"),    # nanoseconds, not seconds
    ("2 nan 0 0 0 0 0 1", "line 2: non-finite x: nan"),
    ("2 0 0 0 0 0 0 inf", "line 2: non-finite qw: inf"),
    ("2 0 1e999 0 0 0 0 1", "line 2: non-finite y: inf"),          # overflows to inf
])
def test_values_must_be_finite_and_sane(tmp_path, line, match):
    f = tmp_path / "huge.tum"
    f.write_text(f"1 0 0 0 0 0 0 1\n{line}\n")
    with pytest.raises(InputError, match=re.escape(match)) as err:
        read_tum(f)
    assert str(err.value).startswith(f"{f}: ") and "\n" not in str(err.value)


def test_positions_outside_the_worlds_bounds_name_the_line(tmp_path):
    f = tmp_path / "far.tum"
    f.write_text("1 0 0 0 0 0 0 1\n2 4.9 1 0 0 0 0 1\n3 1 -2.5 0 0 0 0 1\n")
    bounds = (0.0, 0.0, 3.0, 2.0)
    t, _ = read_tum(f, bounds=bounds, margin=3.0)
    assert len(t) == 3
    with pytest.raises(InputError, match=r"line 3: y: -2.5 m is more than 2 m outside the "
                                         r"world \(0\.\.2 m\)"):
        read_tum(f, bounds=bounds, margin=2.0)
    with pytest.raises(InputError, match=r"line 2: x: 4.9 m is more than 1 m outside the "
                                         r"world \(0\.\.3 m\)"):
        read_tum(f, bounds=bounds, margin=1.0)
