"""from_dict: YAML 1.1 quirks read as a user means them, real type errors still rejected."""
from dataclasses import dataclass, field

import pytest
import yaml

from worlds.yamlio import InputError, from_dict


@dataclass(frozen=True)
class Weights:
    translation: float = 1.0
    rotation: float = 1.0


def test_exponent_without_dot_is_a_number():
    # PyYAML (YAML 1.1) loads 1e5 and 2E-3 as strings; 1.0e+5 as a float
    raw = yaml.safe_load("translation: 1e5\nrotation: -2E-3\n")
    assert isinstance(raw["translation"], str)
    assert from_dict(Weights, raw, where="w.yaml") == Weights(100000.0, -0.002)


@pytest.mark.parametrize("text", ["e5", "1e", "1e5x", "fast", "1,5"])
def test_other_strings_are_still_rejected(text):
    with pytest.raises(InputError, match=r"w\.yaml: translation: expected a number"):
        from_dict(Weights, {"translation": text}, where="w.yaml")


def test_set_override_reads_the_value_as_yaml_and_creates_levels():
    from worlds.yamlio import set_override
    cfg = {"pose_graph": {"optimization_problem": {"huber_scale": 0.1}}}
    set_override(cfg, "pose_graph.optimization_problem.huber_scale=10")
    set_override(cfg, "pose_graph.enable_loop_closure=false")
    set_override(cfg, "trajectory_builder.submaps.resolution=0.1")
    assert cfg == {"pose_graph": {"optimization_problem": {"huber_scale": 10}, "enable_loop_closure": False},
                   "trajectory_builder": {"submaps": {"resolution": 0.1}}}
    with pytest.raises(InputError, match="key.path=value"):
        set_override(cfg, "huber_scale")


@dataclass(frozen=True)
class Matcher:
    weights: Weights = field(default_factory=lambda: Weights(translation=100.0))
    iterations: int = 20


@dataclass(frozen=True)
class Builder:
    local: Matcher = field(default_factory=Matcher)
    loop: Matcher = field(default_factory=lambda: Matcher(Weights(10.0, 0.5), 10))


def test_partial_nested_block_keeps_the_parents_default_for_unnamed_keys():
    # the parent's default_factory, not the nested class's own defaults, fills what a block leaves out
    got = from_dict(Builder, {"local": {"weights": {"rotation": 4}}, "loop": {"iterations": 5}}, where="b.yaml")
    assert got.local == Matcher(Weights(100.0, 4.0), 20)
    assert got.loop == Matcher(Weights(10.0, 0.5), 5)
    assert from_dict(Builder, {}, where="b.yaml") == Builder()


def test_partial_nested_block_still_rejects_unknown_keys_and_bad_values():
    with pytest.raises(InputError, match=r"b\.yaml: loop\.weights\.rotatoin: unknown key"):
        from_dict(Builder, {"loop": {"weights": {"rotatoin": 1}}}, where="b.yaml")
    with pytest.raises(InputError, match=r"b\.yaml: loop\.iterations: expected an integer"):
        from_dict(Builder, {"loop": {"iterations": "many"}}, where="b.yaml")
