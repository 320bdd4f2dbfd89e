"""metrics.registry: the built-in metrics give score_map's keys in order; bad registrations fail."""
import numpy as np
import pytest

from metrics import registry
from metrics.grid_portion import GridPortion
from metrics.registry import Column, Metric, Section
from metrics.score import score_map
from metrics.trajectory import TrajectoryContext
from tests.metrics.maps import ROOM, draw

SCORE_KEYS = [
    "precision", "sensitivity", "f1", "tp", "fp", "fn", "tp_truth", "tolerance",
    "adnn_m", "adnn_cells", "adnn_reverse_m", "adnn_reverse_cells", "chamfer_m", "chamfer_cells",
    "align", "align_mode", "align_inlier_fraction", "align_rms_m", "est_occupied",
    "true_occupied", "resolution", "ssim", "occupied_fraction", "free_fraction", "corners",
    "enclosed_areas"]
SURFACE_KEYS = ["surface_precision", "surface_sensitivity", "surface_f1", "surface_tp",
                "surface_fp", "surface_length_m", "surface_covered_m", "surface_tau_m",
                "surface_align"]


def test_score_map_keys_are_the_registered_ones_in_order():
    truth = draw(ROOM)
    assert list(score_map(truth, truth)) == SCORE_KEYS   # no surfaces: no surface form
    assert list(score_map(truth, truth, gtfree=False)) == SCORE_KEYS[:-5]
    with_surface = SCORE_KEYS[:8] + SURFACE_KEYS + SCORE_KEYS[8:]
    segs = np.array([[0.0, 0.0, 1.0, 0.0]])
    assert list(score_map(truth, truth, surfaces=segs)) == with_surface
    assert [k for m in registry.metrics("map") for k in m.keys if k != "note"] == with_surface


def test_trajectory_metrics_through_the_registry():
    t = np.linspace(0.0, 10.0, 50)
    p = np.stack([t * 0.3, np.sin(t), np.zeros_like(t)], axis=1)
    r = registry.compute("trajectory", TrajectoryContext(t, p, t, p))
    assert r["ate_m"] == pytest.approx(0.0, abs=1e-9) and r["rpe_pairs"] > 0
    assert list(r)[:3] == ["ate_m", "ate_start_m", "ate_yaw_rad"] and "note" not in r


def test_result_leaves_out_an_empty_note():
    full = GridPortion(0.0, 0.0, 0.0, 0, 0, 5, 0, 0, note="empty")
    assert list(GridPortion(1.0, 1.0, 1.0, 3, 0, 0, 3, 0).as_dict())[-1] == "tolerance"
    assert full.as_dict()["note"] == "empty"


def test_builtin_columns_and_tolerances():
    keys = [c.key for c in registry.columns()]
    assert {"precision", "sensitivity_t1", "adnn_cells", "ate_m", "realtime_factor"} <= set(keys)
    assert registry.tolerances()["precision"] == ("drop", 0.03)
    assert registry.tolerances()["adnn_cells"] == ("rise", 0.3)
    assert registry.tolerances()["surface_precision"] == ("drop", 0.03)
    assert registry.tolerances()["surface_sensitivity"] == ("drop", 0.03)
    assert [s.name for s in registry.sections()][:4] == ["adnn", "ps", "ps_cell", "ps_t1"]
    shown = {c.key: c for c in registry.columns()}
    assert shown["surface_precision"].section == "ps" and shown["precision"].section == "ps_cell"
    assert {c.key: c.fallback for c in registry.columns() if c.fallback} == {
        "surface_precision": "precision", "surface_sensitivity": "sensitivity",
        "surface_f1": "f1"}


def _metric(name="toy", keys=("toy_value",), **kw):
    args = dict(compute=lambda ctx: None, columns=(Column(keys[0], "toy", 2, True),))
    return Metric(name, "map", keys, **(args | kw))


@pytest.mark.parametrize("metric, message", [
    (_metric(name="adnn"), "already registered"),
    (_metric(keys=("precision",)), "reported by another metric"),
    (_metric(columns=()), "shows no column"),
    (_metric(columns=(Column("other", "x"),)), "none of its keys"),
    (_metric(columns=(Column("toy_value_t1", "x"),)), "none of its keys"),
    (_metric(columns=(Column("toy_value", "x", section="nope"),)), "no section 'nope'"),
    (_metric(columns=(Column("toy_value", "x", tolerance=0.1),)), "no better direction"),
    (_metric(columns=(Column("toy_value", "x", fallback="nope"),)), "fallback 'nope'"),
    (_metric(compute=None), "no compute function"),
    (Metric("toy", "sometimes", ("toy_value",), (Column("toy_value", "x"),), compute=len),
     "kind must be one of"),
])
def test_register_rejects_inconsistent_metrics(metric, message):
    with pytest.raises(ValueError, match=message):
        registry.register(metric)
    assert "toy" not in [m.name for m in registry.metrics()]


def test_per_tolerance_columns_must_name_a_per_tolerance_key():
    m = _metric(per_tolerance=("toy_value",), columns=(Column("toy_value_t1", "x"),))
    registry.register(m)
    try:
        assert registry.columns()[-1].key == "toy_value_t1"
    finally:
        registry.unregister("toy")
    with pytest.raises(ValueError, match="already registered"):
        registry.register_section(Section("adnn", "again"))


def test_entry_point_metric_plugins_load_after_the_builtins(monkeypatch):
    """A `slam_bench.metrics` entry point is registered the first time the registry is read,
    after the built-ins, and its key reaches score_map; a broken one is a one-line InputError."""
    import importlib.metadata as md
    from worlds.yamlio import InputError
    good = md.EntryPoint("plugin_points", "tests.metrics.plugin_metric:PLUGIN_POINTS",
                         registry.ENTRY_POINT_GROUP)
    groups = []

    def entry_points(group=None):
        groups.append(group)
        return [good]
    monkeypatch.setattr(registry, "entry_points", entry_points)
    monkeypatch.setattr(registry, "_plugins_loaded", False)
    try:
        assert [c.key for c in registry.columns()][-1] == "plugin_points"
        assert groups == ["slam_bench.metrics"]
        truth = draw(ROOM)
        assert score_map(truth, truth)["plugin_points"] == len(truth.occupied().nonzero()[0])
        assert registry.load_plugins() == ["plugin_points"]   # again: already registered
    finally:
        registry.unregister("plugin_points")
    bad = md.EntryPoint("broken", "tests.metrics.no_such_module", registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "entry_points", lambda group=None: [bad])
    monkeypatch.setattr(registry, "_plugins_loaded", False)
    with pytest.raises(InputError, match="metric plugin 'broken'.*failed to load"):
        registry.columns()
    with pytest.raises(InputError, match="metric plugin 'broken'"):
        registry.metrics()   # not taken as loaded: every read names it
