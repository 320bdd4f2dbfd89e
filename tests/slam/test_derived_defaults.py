"""Defaults from the log (slam.sensors, each algorithm's derive_config, slam.registry): an
LDS-01 log resolves to the config classes' defaults; other sensor classes get what their
ranges, beams, rates and noise mean; a value set in a config wins; `slam run --explain`."""
import math

import pytest

from slam.gn.defaults import derive_gn_config
from slam.graph.defaults import derive_graph_config
from slam.pf.defaults import derive_pf_config
from slam.registry import explain_config, get, load_config
from slam.sensors import apply_derived, sensor_facts
from tests.slam.sensor_classes import LDS01, NO_ODOMETRY, SICK_GFS, UTM30LX
from worlds.yamlio import to_dict

DERIVE = {"pf": derive_pf_config, "gn": derive_gn_config, "graph": derive_graph_config}


def _values(derived):
    return {d.path: d.value for d in derived}


@pytest.mark.parametrize("algo", sorted(DERIVE))
def test_an_lds01_log_resolves_to_the_class_defaults(algo):
    cls = get(algo).config_class
    assert to_dict(apply_derived(cls(), DERIVE[algo](LDS01))) == to_dict(cls())


def test_pf_on_a_long_range_dense_scanner():
    v = _values(derive_pf_config(UTM30LX))
    assert v["max_urange"] == 30.0 and v["map_extent"] == 50.0
    assert v["matcher.lskip"] == 2            # every third of 1081 beams: about 360 matched
    assert v["smooth_beams"] == 1             # +-30 mm: sigma 15 mm against a 12.5 mm quarter cell
    assert v["throttle_scans"] == 8           # 40 Hz: the filter takes scans at 5 Hz
    assert "odometry_heading" not in v         # it has a gyro: the TurtleBot3's odometry
    # it reaches past 4 m: GMapping's 0.05 m cells and the pull to the prior that goes with them
    assert (v["delta"], v["matcher.gn_prior_weight"]) == (0.05, 3.0)
    v = _values(derive_pf_config(SICK_GFS))
    assert v["max_urange"] == 80.0 and v["map_extent"] == 100.0
    assert v["smooth_beams"] == 0 and v["matcher.lskip"] == 0 and v["throttle_scans"] == 1
    assert v["delta"] == 0.05
    # no gyro: the wheels' odometry with GMapping's motion noise
    assert v["odometry_heading"] == "wheels"
    assert [v[f"motion.{k}"] for k in ("srr", "srt", "str", "stt")] == [0.1, 0.2, 0.1, 0.2]


def test_gn_uses_the_gyro_only_when_the_log_has_one():
    assert _values(derive_gn_config(SICK_GFS))["use_imu"] is False
    assert _values(derive_gn_config(UTM30LX))["use_imu"] is True


def test_graph_on_a_fast_scanner_and_on_a_thinned_log():
    v = _values(derive_graph_config(UTM30LX))
    tb = "trajectory_builder."
    assert v[tb + "max_range"] == 30.0 and v[tb + "min_range"] == 0.1
    assert v[tb + "motion_filter.max_angle_radians"] == pytest.approx(math.radians(0.8))
    assert v[tb + "submaps.range_sigma_min"] == pytest.approx(0.015)
    assert v[tb + "use_online_correlative_scan_matching"] is False
    # 8 times the scans per second: the pulls to the prediction sqrt(8) times stronger per scan
    assert v[tb + "ceres_scan_matcher.translation_weight"] == pytest.approx(300.0 * math.sqrt(8), rel=1e-3)
    assert v[tb + "ceres_scan_matcher.rotation_weight"] == pytest.approx(330.0 * math.sqrt(8), rel=1e-3)
    v = _values(derive_graph_config(SICK_GFS))
    assert v[tb + "ceres_scan_matcher.translation_weight"] == 10.0
    assert tb + "ceres_scan_matcher.rotation_weight" not in v
    assert v[tb + "use_online_correlative_scan_matching"] is True
    assert v[tb + "real_time_correlative_scan_matcher.linear_search_window"] == pytest.approx(0.2)
    assert v[tb + "submaps.num_range_data"] == 30 and v["pose_graph.optimize_every_n_nodes"] == 30
    assert v[tb + "use_imu_data"] is False and v[tb + "missing_data_ray_length"] == 5.0
    assert v[tb + "adaptive_voxel_filter.max_range"] == 80.0
    # without odometry the prediction is coarse: the online correlative matcher searches, and
    # the least squares pulls towards it are Cartographer's
    v = _values(derive_graph_config(NO_ODOMETRY))
    assert v[tb + "use_online_correlative_scan_matching"]
    assert v[tb + "ceres_scan_matcher.translation_weight"] == 10.0
    assert v[tb + "ceres_scan_matcher.rotation_weight"] == 40.0


def _log(lidar="utm-30lx"):
    import sim
    import worlds
    return sim.record(worlds.load_world("rectangle_s"), seed=1, lidar=lidar)


def test_facts_of_a_recorded_270_degree_log():
    f = sensor_facts(_log())
    assert f.beams == 1081 and f.field_of_view == pytest.approx(math.radians(270.25))
    assert f.scan_rate == pytest.approx(40.0) and f.time_increment == pytest.approx(0.025 / 1440)
    assert f.noise_known and f.range_noise.sigma(5.0) == pytest.approx(0.015)
    assert f.odometry and f.imu and 0 < f.scan_step < 0.01


def test_a_value_the_config_sets_wins_over_the_derived_one():
    log = _log()
    assert load_config("pf", None, log=log).max_urange == 30.0
    cfg = load_config("pf", {"max_urange": 8.0, "matcher": {"sigma": 0.04}}, log=log)
    assert cfg.max_urange == 8.0 and cfg.matcher.sigma == 0.04 and cfg.matcher.lskip == 2
    rows = {d.path: over for d, over in explain_config("pf", {"max_urange": 8.0}, log)}
    assert rows["max_urange"] is True and rows["matcher.lskip"] is False
    # a config dataclass is taken as it is
    assert load_config("pf", get("pf").config_class(), log=log).max_urange == 3.5


def test_explain_prints_each_rule(tmp_path, capsys):
    from sim.logs import write_log
    from slam.__main__ import main
    write_log(_log(), tmp_path / "utm.npz")
    cfg = tmp_path / "g.yaml"
    cfg.write_text("trajectory_builder: {max_range: 12.0}\n")
    assert main(["run", "--algo", "graph", "--log", str(tmp_path / "utm.npz"), "--explain",
                 "--config", str(cfg)]) == 0
    out = capsys.readouterr().out
    assert "| trajectory_builder.motion_filter.max_angle_radians | 0.0139626 | 0.1 degree at 5 Hz" in out
    assert "| trajectory_builder.max_range | 30 | the sensor's range_max (--config sets it instead) |" in out
    assert not (tmp_path / "out").exists()
    assert main(["run", "--algo", "graph", "--log", str(tmp_path / "utm.npz")]) == 2
    assert "--out is required" in capsys.readouterr().err
