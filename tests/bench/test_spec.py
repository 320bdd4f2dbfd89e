"""bench.spec: `bench run`'s options -> the RunSpec, without the command line."""
import json

import pytest

from bench.plan import RunSpec
from bench.results import RUN_NAME
from bench.spec import spec_from_options
from worlds.yamlio import InputError


def test_a_world_and_the_defaults(tiny):
    spec = spec_from_options(world=tiny, algo="fake_map,fake_raise")
    assert spec == RunSpec(worlds=(tiny,), algos=("fake_map", "fake_raise"), repeats=10,
                           noise="realistic", seed=0, vary="slam", draws=1, min_coverage=0.95)
    spec = spec_from_options(world=tiny, algo="fake_map", repeats=3, seed=7, vary="data",
                             shard=(2, 3), sets=["fake_map.pose_noise_m=0.5"])
    assert (spec.repeats, spec.seed, spec.vary, spec.shard) == (3, 7, "data", (2, 3))
    assert spec.overrides == {"fake_map": {"pose_noise_m": 0.5}}


@pytest.mark.parametrize("options, message", [
    ({}, "--world, --suite or --logs is required"),
    ({"world": "x", "suite": "general"}, "give one of --world, --suite and --logs"),
    ({"world": "rectangle_s", "algo": "nope"}, "unknown algorithm 'nope'"),
])
def test_options_that_do_not_fit(options, message):
    with pytest.raises(InputError, match=message):
        spec_from_options(**options)


def test_a_resumed_run_keeps_its_spec_unless_an_option_changes_it(tiny, tmp_path):
    stored = RunSpec(worlds=(tiny,), algos=("fake_map",), repeats=2, seed=3)
    run = {"spec": stored.to_json(), "worlds": {"tiny": {}}}
    (tmp_path / RUN_NAME).write_text(json.dumps(run))
    assert spec_from_options(resume=tmp_path) == stored
    changed = spec_from_options(resume=tmp_path, repeats=4)
    assert changed == RunSpec(worlds=(tiny,), algos=("fake_map",), repeats=4, seed=3)
