"""Names that become parts of paths, and the check that keeps every write inside its folder.

A name taken from a file (a world's `name:`, an algorithm, a suite, a results row, a log's
meta) may hold letters, digits and `_ . + -`, may not start with a dot and is at most 100
characters long (docs/formats.md, "Names"). `path_inside(root, *parts)` resolves the target
and refuses any that lands outside `root` (through `..`, an absolute part or a symlink).
"""
from __future__ import annotations

import os
import re
from pathlib import Path

from worlds.yamlio import InputError, short

__all__ = ["MAX_NAME_LENGTH", "check_name", "is_name", "names_a_file", "path_inside"]

MAX_NAME_LENGTH = 100
_NAME = re.compile(r"[A-Za-z0-9_+\-][A-Za-z0-9_.+\-]*")


def is_name(value: object) -> bool:
    """True when `value` is a string that may become part of a path (see the module doc)."""
    return (isinstance(value, str) and len(value) <= MAX_NAME_LENGTH
            and _NAME.fullmatch(value) is not None)


def names_a_file(text: str) -> bool:
    """True when `text`, where a shipped name or a file may be given (a world, a suite, a noise
    profile, a lidar), is a file: it ends in .yaml or .yml or holds a path separator."""
    text = str(text)
    return (Path(text).suffix.lower() in (".yaml", ".yml") or "/" in text or "\\" in text
            or os.sep in text)


def check_name(value: object, where: str, field: str) -> str:
    """`value` when it is a name (is_name), else InputError '<where>: <field>: ...'."""
    if is_name(value):
        return value
    if not isinstance(value, str):
        raise InputError(f"{where}: {field}: expected a name, got {short(value)}")
    if not value:
        why = "is empty"
    elif len(value) > MAX_NAME_LENGTH:
        why = f"is {len(value)} characters long, more than {MAX_NAME_LENGTH}"
    elif value.startswith("."):
        why = "starts with a dot"
    else:
        why = "holds characters other than letters, digits and _ . + -"
    raise InputError(f"{where}: {field}: {short(value)} {why} (a name becomes part of a file "
                     "path: letters, digits and _ . + -, not starting with a dot)")


def path_inside(root: str | os.PathLike, *parts: str | os.PathLike, what: str = "") -> Path:
    """root/parts... as joined (so that `relative_to(root)` works); InputError when, resolved,
    it lands outside `root` (resolved too).

    what: how the error names the path's source (default: the joined relative path).
    """
    base = Path(root).resolve()
    target = base.joinpath(*parts).resolve()
    if target != base and base not in target.parents:
        rel = os.path.join(*map(str, parts)) if parts else ""
        raise InputError(f"{what or short(rel)}: would write {short(str(target))}, outside the "
                         f"folder {short(str(base))}")
    return Path(root).joinpath(*parts)
