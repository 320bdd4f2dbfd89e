"""The config fields of an algorithm as a table: dotted name, default and the comment that
documents the field in its config dataclass (`python -m slam fields ALGO`; the same tables
stand in docs/algorithms/ALGO.md, kept in sync by a test)."""
from __future__ import annotations

import ast
import dataclasses
import inspect
import textwrap
from dataclasses import dataclass
from functools import lru_cache

__all__ = ["FieldDoc", "config_fields", "field_table", "with_field_table"]


@dataclass(frozen=True)
class FieldDoc:
    """One leaf field: dotted path, default value and its documenting comment."""

    path: str
    default: object
    doc: str


@lru_cache(maxsize=None)
def _comments(cls: type) -> dict[str, str]:
    """Field name -> comment text of a dataclass: the trailing comment of the field's line and
    its comment-only continuation lines, else the comment block right above it."""
    out: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if not dataclasses.is_dataclass(klass):
            continue
        lines, _ = inspect.getsourcelines(klass)
        src = textwrap.dedent("".join(lines)).splitlines()
        for node in ast.parse("\n".join(src)).body[0].body:
            if not (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)):
                continue
            row = node.lineno - 1
            text = []
            line = src[node.end_lineno - 1]
            if "#" in line:
                text.append(line.split("#", 1)[1].strip())
                k = node.end_lineno
                # continuation lines are indented past the field itself
                indent = len(line) - len(line.lstrip())
                while (k < len(src) and src[k].strip().startswith("#")
                       and len(src[k]) - len(src[k].lstrip()) > indent):
                    text.append(src[k].strip()[1:].strip())
                    k += 1
            else:
                k = row - 1
                while k >= 0 and src[k].strip().startswith("#"):
                    text.insert(0, src[k].strip()[1:].strip())
                    k -= 1
            out[node.target.id] = " ".join(t for t in text if t)
    return out


def config_fields(cls: type, prefix: str = "") -> list[FieldDoc]:
    """Every leaf field of the config dataclass `cls` (nested blocks flattened to dotted paths)."""
    rows = []
    defaults = cls()
    docs = _comments(cls)
    for f in dataclasses.fields(cls):
        value = getattr(defaults, f.name)
        if dataclasses.is_dataclass(value):
            block = config_fields(type(value), f"{prefix}{f.name}.")
            # a block whose defaults differ from its class's (a lambda default) keeps them
            rows += [dataclasses.replace(r, default=_get(value, r.path[len(prefix) + len(f.name) + 1:]))
                     for r in block]
        else:
            rows.append(FieldDoc(prefix + f.name, value, docs.get(f.name, "")))
    return rows


def _get(obj, dotted: str):
    for part in dotted.split("."):
        obj = getattr(obj, part)
    return obj


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, tuple):
        return "(" + ", ".join(_fmt(x) for x in v) + ")"
    return str(v)


def field_table(cls: type) -> str:
    """The Markdown table of config_fields(cls)."""
    lines = ["| field | default | meaning |", "|---|---|---|"]
    for r in config_fields(cls):
        doc = r.doc.replace("|", "\\|")
        lines.append(f"| `{r.path}` | `{_fmt(r.default)}` | {doc} |")
    return "\n".join(lines) + "\n"


BEGIN, END = "<!-- fields -->", "<!-- /fields -->"


def with_field_table(page: str, cls: type) -> str:
    """`page` (Markdown) with the text between its field-table markers replaced by
    field_table(cls); ValueError when the markers are missing."""
    if BEGIN not in page or END not in page:
        raise ValueError(f"no {BEGIN} ... {END} markers")
    head, rest = page.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return f"{head}{BEGIN}\n{field_table(cls)}{END}{tail}"
