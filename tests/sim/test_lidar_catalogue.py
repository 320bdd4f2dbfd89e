"""The lidar catalogue (sim/lidars/, sim.lidar.load_lidar, `sim record --lidar`): every entry
loads with its datasheet geometry, fields of view below 360 degrees record and cover the walls,
and bad lidar files are one-line errors."""
import math

import numpy as np
import pytest

from sim.lidar import LidarConfig, lidar_names, load_lidar
from worlds.yamlio import InputError

CATALOGUE = {  # name: (beams, field of view deg, Hz, range_max m)
    "lds-01": (360, 360.0, 5.0, 3.5), "lds-02": (360, 360.0, 5.0, 8.0),
    "rplidar-a1": (360, 360.0, 5.5, 12.0), "urg-04lx": (683, 240.0, 10.0, 5.6),
    "utm-30lx": (1081, 270.0, 40.0, 30.0), "tim571": (811, 270.0, 15.0, 25.0),
}


def test_every_catalogue_entry_loads_with_its_datasheet_geometry():
    assert set(CATALOGUE) <= set(lidar_names())
    for name, (beams, fov, rate, rmax) in CATALOGUE.items():
        c = load_lidar(name)
        assert (c.beams, c.rate, c.range_max) == (beams, rate, rmax), name
        span = math.degrees(c.angles[-1] - c.angles[0])
        assert span == pytest.approx(fov if fov < 360 else 359.0, abs=0.01), name
        # a beam's time is the revolution's time over 360 degrees of beams
        assert c.time_increment == pytest.approx(c.scan_time * c.angle_increment / (2 * math.pi))
        assert c.noise.sigma(1.0) > 0


def test_the_utm30lx_reads_as_its_ros_driver_publishes_it():
    c = load_lidar("utm-30lx")
    m = c.meta()
    assert m["angle_min"] == pytest.approx(-2.35619, abs=1e-5)
    assert m["angle_increment"] == pytest.approx(math.radians(0.25))
    assert m["time_increment"] == pytest.approx(1.73611e-05, rel=1e-5)
    assert c.noise.sigma([5.0, 20.0]) == pytest.approx([0.015, 0.025])


def test_the_default_lidar_is_the_lds01_of_the_catalogue():
    d, c = LidarConfig(), load_lidar("lds-01")
    assert np.array_equal(d.angles, c.angles) and d.time_increment == c.time_increment
    r = np.linspace(0.1, 3.5, 100)
    assert np.array_equal(d.noise.sigma(r), c.noise.sigma(r))


def test_a_270_degree_lidar_records_and_sees_the_walls():
    import sim
    import worlds
    log = sim.record(worlds.load_world("rectangle_s"), seed=2, lidar="tim571")
    assert log.scan_ranges.shape[1] == 811
    assert log.meta["lidar"]["model"] == "TiM571" and log.meta["noise"]["lidar"]["stddev"] == 0.02
    assert np.degrees(log.scan_angles[-1] - log.scan_angles[0]) == pytest.approx(270.0)
    assert 1 / np.median(np.diff(log.scan_t)) == pytest.approx(15.0)
    assert log.meta["wall_coverage"] >= 0.95


def test_a_lidar_file_keeps_the_recording_mount_unless_it_sets_one(tmp_path):
    p = tmp_path / "mine.yaml"
    p.write_text("model: mine\nbeams: 90\nangle_min_deg: -45\nangle_max_deg: 45\nrate: 10\n")
    mount = LidarConfig(offset=(0.1, 0.0, 0.0))
    c = load_lidar(p, mounted_as=mount)
    assert c.offset == (0.1, 0.0, 0.0) and c.beams == 90
    assert math.degrees(c.angle_increment) == pytest.approx(90 / 89)


@pytest.mark.parametrize("text, match", [
    ("beams: 720\nangle_min_deg: -180\nangle_max_deg: 180\n", r"overlap: the field of view is more than a revolution"),
    ("angle_min_deg: 10\nangle_max_deg: 5\n", r"angle_max_deg must be above angle_min_deg"),
    ("range_max: 0.05\n", r"need 0 <= range_min < range_max"),
    ("fov: 270\n", r"mine.yaml: fov: unknown key"),
    ("noise: {bands: [[5, 0.01, 0], [2, 0.01, 0]]}\n", r"mine.yaml: noise: bands\[1\]: up_to 2.0"),
    ("- 1\n", r"mine.yaml: top level: expected a mapping"),
    ("beams: 1000000000\n", r"beams must be from 1 to 10,000"),
    ("rate: 1.0e6\n", r"rate must be > 0 and at most 200 Hz"),
    ("beams: 10000\nrate: 100\n", r"beams x rate must be at most 100,000 beams per second"),
    ("range_max: 1.0e9\n", r"range_max must be at most 1000 m"),
])
def test_bad_lidar_files_are_one_line_errors(tmp_path, text, match):
    p = tmp_path / "mine.yaml"
    p.write_text(text)
    with pytest.raises(InputError, match=match):
        load_lidar(p)


def test_unknown_lidar_names_the_catalogue(tmp_path, capsys):
    from sim.__main__ import main
    with pytest.raises(InputError, match=r"unknown lidar 'sick-9000' \(catalogue: lds-01, "):
        load_lidar("sick-9000")
    assert main(["record", "--world", "rectangle_s", "--lidar", "sick-9000",
                 "--out", str(tmp_path / "x.npz")]) == 2
    assert not (tmp_path / "x.npz").exists()
    assert main(["lidars"]) == 0
    assert "utm-30lx" in capsys.readouterr().out
