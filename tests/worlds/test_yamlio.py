"""from_dict: YAML 1.1 quirks read as a user means them, real type errors still rejected."""
from dataclasses import dataclass, field

import pytest
import yaml

from worlds.yamlio import MAX_YAML_BYTES, InputError, from_dict, load_yaml, parse_yaml, short


@dataclass(frozen=True)
class Weights:
    translation: float = 1.0
    rotation: float = 1.0


def test_exponent_without_dot_is_a_number():
    # PyYAML (YAML 1.1) loads 1e5 and 2E-3 as strings; the project's loader as YAML 1.2 does
    assert isinstance(yaml.safe_load("a: 1e5")["a"], str)
    raw = parse_yaml("translation: 1e5\nrotation: -2E-3\n", "w.yaml")
    assert raw == {"translation": 100000.0, "rotation": -0.002}
    assert from_dict(Weights, raw, where="w.yaml") == Weights(100000.0, -0.002)
    assert parse_yaml("[.5e1, +1E+2, 1e, e5, 007, 1.5]", "w.yaml") == [5.0, 100.0, "1e", "e5", 7, 1.5]


def test_aliases_are_refused_before_they_expand():
    bomb = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n"
        for p, c in zip("abcdefgh", "bcdefghi"))
    with pytest.raises(InputError, match=r"^w\.yaml: not valid YAML \(line 2\): aliases"):
        parse_yaml(bomb, "w.yaml")


def test_deep_nesting_and_huge_files_are_refused(tmp_path):
    with pytest.raises(InputError, match="nested deeper than 64 levels"):
        parse_yaml("[" * 100_000 + "]" * 100_000, "w.yaml")
    assert parse_yaml("[" * 60 + "]" * 60, "w.yaml") is not None
    big = tmp_path / "big.yaml"
    big.write_text("a: " + "x" * (MAX_YAML_BYTES + 1))
    with pytest.raises(InputError, match=r"big\.yaml: more than the 1,048,576 bytes"):
        load_yaml(big)
    with pytest.raises(InputError, match="/dev/zero: not a regular file"):
        load_yaml("/dev/zero")
    with pytest.raises(InputError, match=r"w\.yaml: not valid YAML: invalid literal for int"):
        parse_yaml("a: !!int 1.5", "w.yaml")


def test_error_messages_quote_at_most_about_a_hundred_characters():
    with pytest.raises(InputError) as err:
        from_dict(Weights, {"translation": "x" * 100_000}, where="w.yaml")
    text = str(err.value)
    assert text.startswith("w.yaml: translation: expected a number, got 'xxx")
    assert len(text) < 160
    assert short(list(range(10**6))) == "a list of 1,000,000 items"
    assert len(str(InputError("f: " + "y" * 10**6))) <= 400


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
