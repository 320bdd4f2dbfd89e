"""bench.study: each algorithm stands beside the study's family its class declares (Slam.family),
a plugin as a shipped one; the describing attributes are checked when a class is registered."""
import pytest

from bench.study import STUDY, family_of
from bench.tables import summary_markdown
from metrics.surface import DEFAULT_TAU_M
from slam import registry
from tests.bench.fakes import _Base


@pytest.fixture
def plugin():
    """Registers a class under a name for the test (as an entry point would), then forgets it."""
    names = []

    def add(name, **attrs):
        registry.register(name)(type("Plugin", (_Base,), attrs))
        names.append(name)
        return name
    yield add
    for name in names:
        registry._REGISTERED.pop(name, None)


def _rows(algo):
    return [{"world": w, "algo": algo, "repeat": r, "status": "ok", "precision": 0.8,
             "sensitivity": 0.7, "adnn_cells": 0.5, "surface_precision": 0.9,
             "surface_sensitivity": 0.8, "surface_f1": 0.85, "surface_tau_m": DEFAULT_TAU_M}
            for w in ("swirl_s", "hall") for r in range(2)]


def test_shipped_algorithms_declare_their_family():
    assert {a: family_of(a) for a in registry.BUILTIN} == {
        "pf": "Gmapping", "gn": "Hector", "graph": "Cartographer", "oracle": None}
    assert family_of("slam_toolbox") is None       # a map scored elsewhere: no class
    assert set(STUDY) == {"Gmapping", "Hector", "Cartographer"}


def test_a_plugin_of_the_cartographer_family_stands_beside_the_study_row(plugin):
    name = plugin("carto_like", family="Cartographer", uses_ground_truth=False)
    md = summary_markdown(_rows(name))
    assert "## Beside the reference study" in md
    assert ("| world | Cartographer (study) | carto_like (study's cell rule) | carto_like "
            "(surface, ") in md
    # the study's Cartographer on swirl_s: P 0.92, S 0.98; ADNN 0.11 cells
    assert "| swirl_s | 0.92 / 0.98 | 0.800 ± 0.000 / 0.700 ± 0.000 | 0.900 ± 0.000 / " in md
    assert "| swirl_s | 0.11 | 0.50 ± 0.00 |" in md
    # beside the shipped graph, the same study column again
    both = summary_markdown(_rows(name) + _rows("graph"))
    assert "| world | Cartographer (study) | graph (study's cell rule)" in both
    assert both.count("Cartographer (study)") == 4   # two tables x (graph, carto_like)


def test_no_family_or_one_the_study_did_not_run_stands_beside_nothing(plugin):
    for name in (plugin("plain"), plugin("karto_like", family="Karto")):
        assert family_of(name) is None
        assert "reference study" not in summary_markdown(_rows(name))


def test_describing_attributes_have_defaults_and_are_checked(plugin):
    cls = registry.get(plugin("plain", uses_ground_truth=False))
    assert (cls.family, cls.compile_cost_s, cls.uses_ground_truth, cls.warmup_scans) == \
        (None, 0.0, False, 12)
    for attrs, message in (({"family": 3}, "family must be a name"),
                           ({"family": ""}, "family must be a name"),
                           ({"compile_cost_s": -1.0}, "compile_cost_s must be"),
                           ({"compile_cost_s": "slow"}, "compile_cost_s must be"),
                           ({"uses_ground_truth": "yes"}, "uses_ground_truth must be"),
                           ({"warmup_scans": 0}, "warmup_scans must be")):
        with pytest.raises(TypeError, match=message):
            plugin("bad", **attrs)
    assert "bad" not in registry.names()
