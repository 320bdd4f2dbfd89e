"""from_dict: YAML 1.1 quirks read as a user means them, real type errors still rejected."""
from dataclasses import dataclass

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
