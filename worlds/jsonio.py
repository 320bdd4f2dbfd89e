"""Strict JSON, the one way every package reads and writes it.

Writing (`jsonable`, `dumps`): NaN and infinities become null, as JSON has neither; numpy
scalars and arrays become Python numbers and lists, tuples lists, mapping keys strings. The
text is standard JSON that any reader takes, never Python's NaN / Infinity extensions.
Reading (`loads`, `read_json`): InputError naming the file when the text is not valid JSON,
nests lists and mappings more than MAX_JSON_DEPTH deep, or (a file) is larger than its cap or
not UTF-8.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from worlds.yamlio import InputError

__all__ = ["jsonable", "dumps", "loads", "read_json", "deeper_than", "MAX_JSON_DEPTH"]

# deeper than the YAML cap (64: configs stored in JSON files may reach it), far below
# Python's recursion limit (1000), which deep JSON would otherwise hit in every reader
MAX_JSON_DEPTH = 100


def jsonable(value: Any) -> Any:
    """`value` as plain JSON data: numpy scalars -> Python numbers, arrays and tuples -> lists,
    keys -> str, NaN and +-inf -> None."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def dumps(value: Any, **kwargs) -> str:
    """Strict JSON text of `value` (`jsonable` first); kwargs go to json.dumps (indent,
    sort_keys)."""
    return json.dumps(jsonable(value), allow_nan=False, **kwargs)


def loads(text: str, where: str, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """The value of JSON `text`; InputError naming `where` when it is not valid JSON or is
    nested deeper than `max_depth` (lists and mappings in one another)."""
    try:
        value = json.loads(text)
    except RecursionError:   # json's own recursion, at a depth near Python's limit
        raise InputError(f"{where}: JSON nested deeper than {max_depth} levels") from None
    except ValueError as err:   # JSONDecodeError, or an integer of more than 4300 digits
        raise InputError(f"{where}: not valid JSON: {' '.join(str(err).split())[:200]}") from None
    if deeper_than(value, max_depth):
        raise InputError(f"{where}: JSON nested deeper than {max_depth} levels")
    return value


def read_json(path: str | os.PathLike, what: str, max_bytes: int) -> dict:
    """The JSON object in file `path`; InputError naming the file when it is missing, larger
    than `max_bytes`, not UTF-8 text (a binary file), not valid JSON, nested too deeply
    (`loads`) or not an object. what: the kind of file, for the message."""
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > max_bytes:
            raise InputError(f"{p}: {size:,} bytes, more than the {max_bytes:,} a {what} "
                             "may have")
        raw = p.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{p}: file not found") from None
    except OSError as err:
        raise InputError(f"{p}: cannot read: {err.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise InputError(f"{p}: not a text file (byte {err.start} is not UTF-8): not a "
                         f"{what}") from None
    data = loads(text, str(p))
    if not isinstance(data, dict):
        raise InputError(f"{p}: not a {what} (expected a JSON object, got "
                         f"{type(data).__name__})")
    return data


def deeper_than(value: Any, limit: int) -> bool:
    """Whether lists and dicts nest more than `limit` levels in `value` (iterative: a deep
    value must not exhaust the recursion this check is there to protect)."""
    stack = [(value, 1)] if isinstance(value, (dict, list)) else []
    while stack:
        v, depth = stack.pop()
        if depth > limit:
            return True
        children = v.values() if isinstance(v, dict) else v
        stack.extend((c, depth + 1) for c in children if isinstance(c, (dict, list)))
    return False
