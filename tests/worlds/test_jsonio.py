"""worlds.jsonio: strict JSON out (NaN and infinities as null, numpy as plain data), checked
JSON in (valid, not too deep, a file not too large and UTF-8)."""
import json

import numpy as np
import pytest

from worlds.jsonio import MAX_JSON_DEPTH, dumps, jsonable, loads, read_json
from worlds.yamlio import InputError


def test_non_finite_numbers_become_null_and_numpy_plain_data():
    value = {"nan": float("nan"), "inf": float("inf"), "-inf": -np.inf, "f32": np.float32(np.nan),
             "i64": np.int64(3), "b": np.bool_(True), "arr": np.array([1.0, np.inf]),
             "zero_d": np.array(2.5), "tuple": (1, np.float64(0.5)), 7: "int key"}
    assert jsonable(value) == {"nan": None, "inf": None, "-inf": None, "f32": None, "i64": 3,
                               "b": True, "arr": [1.0, None], "zero_d": 2.5, "tuple": [1, 0.5],
                               "7": "int key"}
    text = dumps(value, sort_keys=True)
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text)["arr"] == [1.0, None]


def test_dumps_passes_the_layout_options_on():
    assert dumps({"b": 1, "a": [1, 2]}, indent=1, sort_keys=True) == json.dumps(
        {"a": [1, 2], "b": 1}, indent=1)
    assert dumps({"b": 1, "a": 2}) == '{"b": 1, "a": 2}'


def test_loads_reads_what_dumps_writes():
    value = {"a": [1, 2.5, None, "x"], "b": {"c": True}}
    assert loads(dumps(value), "here") == value


@pytest.mark.parametrize("text, message", [
    ("{", "here: not valid JSON"),
    ("[" * (MAX_JSON_DEPTH + 1) + "]" * (MAX_JSON_DEPTH + 1), "here: JSON nested deeper than 100"),
    ("[" * 100_000 + "]" * 100_000, "here: JSON nested deeper than 100"),
])
def test_loads_refuses_with_one_line_naming_the_place(text, message):
    with pytest.raises(InputError, match=message) as err:
        loads(text, "here")
    assert "\n" not in str(err.value)


def test_loads_takes_the_deepest_allowed():
    text = "[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH
    assert loads(text, "here") is not None


def test_read_json_checks_the_file(tmp_path):
    good = tmp_path / "good.json"
    good.write_text('{"a": 1}')
    assert read_json(good, "run file", 100) == {"a": 1}
    with pytest.raises(InputError, match="more than the 3 a run file may have"):
        read_json(good, "run file", 3)
    binary = tmp_path / "bin.json"
    binary.write_bytes(b"\xff\xfe{}")
    with pytest.raises(InputError, match="not a text file .*: not a run file"):
        read_json(binary, "run file", 100)
    listing = tmp_path / "list.json"
    listing.write_text("[1]")
    with pytest.raises(InputError, match="not a run file \\(expected a JSON object, got list\\)"):
        read_json(listing, "run file", 100)
    with pytest.raises(InputError, match="file not found"):
        read_json(tmp_path / "none.json", "run file", 100)
