import pytest

from bench.plan import RunSpec, make_tasks, parse_configs, parse_worlds, resolve_algos, seeds_for
from worlds.yamlio import InputError


def test_seeds_follow_vary():
    assert [seeds_for("slam", 5, r) for r in range(3)] == [(5, 5), (5, 6), (5, 7)]
    assert [seeds_for("data", 5, r) for r in range(3)] == [(5, 5), (6, 5), (7, 5)]
    assert [seeds_for("both", 5, r) for r in range(3)] == [(5, 5), (6, 6), (7, 7)]


def test_tasks_cover_the_matrix_once():
    spec = RunSpec(worlds=("a", "b"), algos=("fake_map", "fake_raise"), repeats=3, seed=1)
    tasks = make_tasks(spec)
    assert len(tasks) == 12
    assert len({t.key for t in tasks}) == 12
    # one log per world with vary=slam: the study's protocol
    assert {t.log_seed for t in tasks} == {1}
    assert sorted({t.slam_seed for t in tasks}) == [1, 2, 3]
    assert [t.repeat for t in tasks[:4]] == [0, 0, 0, 0]


@pytest.mark.parametrize("kw, msg", [
    ({"repeats": 0}, "--repeats"), ({"repeats": -2}, "--repeats"), ({"vary": "x"}, "--vary"),
    ({"worlds": ()}, "no world"),
])
def test_bad_spec(kw, msg):
    args = dict(worlds=("a",), algos=("fake_map",), repeats=1) | kw
    with pytest.raises(InputError, match=msg):
        RunSpec(**args)


def test_spec_json_round_trip():
    spec = RunSpec(worlds=("a",), algos=("fake_map",), repeats=2, configs={"fake_map": "/x.yaml"})
    assert RunSpec.from_json(spec.to_json()) == spec


def test_algos_resolve_and_reject_unknown():
    assert resolve_algos("fake_map,fake_raise,fake_map") == ["fake_map", "fake_raise"]
    assert "fake_map" in resolve_algos(None)
    with pytest.raises(InputError, match="unknown algorithm 'nope'"):
        resolve_algos("fake_map,nope")


def test_worlds_parse():
    assert parse_worlds("a, b,a") == ["a", "b"]
    import worlds
    assert parse_worlds("all") == worlds.list_worlds()
    with pytest.raises(InputError):
        parse_worlds(" ")


def test_config_files_checked(tmp_path):
    good = tmp_path / "good.yaml"
    good.write_text("pose_noise_m: 0.02\n")
    bad = tmp_path / "bad.yaml"
    bad.write_text("pose_noise: 0.02\n")
    assert parse_configs([f"fake_map={good}"], ["fake_map"]) == {"fake_map": str(good.resolve())}
    with pytest.raises(InputError, match="pose_noise: unknown key"):
        parse_configs([f"fake_map={bad}"], ["fake_map"])
    with pytest.raises(InputError, match="not in this run"):
        parse_configs([f"fake_raise={good}"], ["fake_map"])
    with pytest.raises(InputError, match="ALGO=YAML"):
        parse_configs([str(good)], ["fake_map"])


def test_entry_point_plugins(monkeypatch):
    import importlib.metadata as md
    from slam import registry
    from bench.plan import load_plugins
    good = md.EntryPoint("plugin_algo", "tests.bench.plugin_algo:PluginAlgo", "slam_bench.algorithms")
    monkeypatch.setattr(registry, "entry_points", lambda group=None: [good])
    monkeypatch.delitem(registry._REGISTERED, "plugin_algo", raising=False)
    try:
        assert load_plugins() == ["plugin_algo"]
        assert "plugin_algo" in resolve_algos("plugin_algo,fake_map")
    finally:
        registry._REGISTERED.pop("plugin_algo", None)
    bad = md.EntryPoint("broken", "tests.bench.no_such_module", "slam_bench.algorithms")
    monkeypatch.setattr(registry, "entry_points", lambda group=None: [bad])
    with pytest.raises(InputError, match="plugin 'broken'.*failed to load"):
        load_plugins()
