"""YAML loading and dataclass configs shared by every package.

`InputError` is the one error type for what a user gave us (a bad file or field);
commands print it as one line and exit 2. Bugs keep their traceback.
`from_dict(cls, data, where)` builds a (nested) dataclass from a mapping, rejecting
unknown keys with a "did you mean" hint and wrong types with the field's path.
"""
from __future__ import annotations

import dataclasses
import math
import difflib
import os
import re
import stat
import tempfile
import types
import typing
from pathlib import Path
from typing import Any, Mapping

import yaml

_EXPONENT_FLOAT = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+$")

__all__ = ["InputError", "load_yaml", "parse_yaml", "from_dict", "to_dict", "dump_yaml",
           "set_override", "short", "atomic_write_bytes", "atomic_write_text", "MAX_YAML_BYTES",
           "MAX_YAML_DEPTH"]

# PyYAML's safe loader reads about 65 kB/s of dense YAML: a file of the cap parses in ~15 s
MAX_YAML_BYTES = 1024 * 1024
MAX_YAML_DEPTH = 64
_MAX_MESSAGE = 400
_MAX_QUOTE = 100
# the largest integer a config may hold: exact as a float, fits the compiled kernels' int64
_MAX_INT = 2**53


class InputError(ValueError):
    """A problem with user input: names the file, the field and what is wrong.

    A message longer than a few hundred characters is cut in the middle, so that a huge value
    never floods the terminal; quote values with `short` to keep the cut off the field.
    """

    def __init__(self, message: object = "") -> None:
        text = str(message)
        if len(text) > _MAX_MESSAGE:
            text = text[:_MAX_MESSAGE - 60] + " ... " + text[-55:]
        super().__init__(text)


def short(value: Any, limit: int = _MAX_QUOTE) -> str:
    """repr(value), cut to about `limit` characters for an error message."""
    if isinstance(value, (list, tuple, dict)) and len(value) > limit:
        # repr of a huge container costs memory before it can be cut
        return f"a {type(value).__name__} of {len(value):,} items"
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 4] + " ..."


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader with YAML 1.2's exponent numbers (1e5 is a float, as every user
    means), no aliases (a few hundred bytes of nested aliases expand to gigabytes) and a cap
    on nesting (deep nesting exhausts the recursion of the composer)."""

    def __init__(self, stream) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            raise yaml.composer.ComposerError(
                None, None, "aliases (*name) are not accepted", self.peek_event().start_mark)
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise yaml.composer.ComposerError(
                    None, None, f"nested deeper than {MAX_YAML_DEPTH} levels",
                    self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+.0123456789"))


def parse_yaml(text: str, where: str) -> Any:
    """Parse YAML text with the project's loader; InputError naming `where` when it is not
    valid YAML, holds an alias, is nested too deeply or is larger than MAX_YAML_BYTES."""
    if len(text) > MAX_YAML_BYTES:
        raise InputError(f"{where}: {len(text):,} characters, more than the {MAX_YAML_BYTES:,} "
                         "a YAML file may have")
    try:
        return yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        at = f" (line {mark.line + 1})" if mark is not None else ""
        problem = " ".join(str(getattr(err, "problem", None) or err).split())[:200]
        raise InputError(f"{where}: not valid YAML{at}: {problem}") from None
    except RecursionError:
        raise InputError(f"{where}: not valid YAML: nested too deeply") from None
    except (ValueError, OverflowError) as err:   # a tag the constructor refuses: !!int 1.5
        raise InputError(f"{where}: not valid YAML: {' '.join(str(err).split())[:200]}") from None


def load_yaml(path: str | os.PathLike) -> Any:
    """Parse a YAML file; a missing or malformed file raises InputError naming it."""
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                raise InputError(f"{p}: not a regular file")
            data = fh.read(MAX_YAML_BYTES + 1)   # a device (/dev/zero) has no size to check
        if len(data) > MAX_YAML_BYTES:
            raise InputError(f"{p}: more than the {MAX_YAML_BYTES:,} bytes a YAML file may have")
        text = data.decode("utf-8")
    except FileNotFoundError:
        raise InputError(f"{p}: file not found") from None
    except UnicodeDecodeError as err:
        raise InputError(f"{p}: not a text file (byte {err.start} is not UTF-8)") from None
    except OSError as err:
        raise InputError(f"{p}: cannot read: {err.strerror}") from None
    return parse_yaml(text, str(p))


def _suggest(key: str, allowed: list[str]) -> str:
    close = difflib.get_close_matches(key, allowed, n=1)
    return f" (did you mean '{close[0]}'?)" if close else f" (allowed: {', '.join(allowed)})"


def check_keys(data: Mapping, allowed: list[str], where: str, field: str = "") -> None:
    """InputError '<where>: <field>.<key>: unknown key (did you mean ...)' for the first key of
    the mapping `data` not in `allowed` (field "": top-level keys)."""
    for key in data:
        if key not in allowed:
            at = f"{field}.{key}" if field else str(key)
            raise InputError(f"{where}: {at}: unknown key{_suggest(str(key), allowed)}")


def _convert(tp: Any, value: Any, where: str, field: str) -> Any:
    """Convert `value` to type `tp`, raising InputError that names `where: field`."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _convert(a, value, where, field)
            except InputError as err:
                errors.append(str(err))
        raise InputError(errors[0] if errors else f"{where}: {field}: unexpected null")
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, Mapping):
            raise InputError(f"{where}: {field}: expected a mapping, got {short(value)}")
        return from_dict(tp, value, where, prefix=f"{field}.")
    if tp is bool:
        if not isinstance(value, bool):
            raise InputError(f"{where}: {field}: expected true or false, got {short(value)}")
        return value
    if tp is int:
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{where}: {field}: expected an integer, got {short(value)}")
        if abs(value) > _MAX_INT:
            raise InputError(f"{where}: {field}: {short(value)} is beyond {_MAX_INT:,} (2^53)")
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"{where}: {field}: expected a number, got {short(value)}")
        if not math.isfinite(value):
            raise InputError(f"{where}: {field}: expected a finite number, got {short(value)}")
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise InputError(f"{where}: {field}: expected a string, got {short(value)}")
        return value
    if origin is tuple or tp is tuple:
        if not isinstance(value, (list, tuple)):
            raise InputError(f"{where}: {field}: expected a list, got {short(value)}")
        if args and args[-1] is not Ellipsis:
            if len(value) != len(args):
                raise InputError(f"{where}: {field}: expected {len(args)} values, got {len(value)}")
            return tuple(_convert(a, v, where, f"{field}[{i}]") for i, (a, v) in enumerate(zip(args, value)))
        inner = args[0] if args else Any
        return tuple(_convert(inner, v, where, f"{field}[{i}]") for i, v in enumerate(value))
    if origin is list or tp is list:
        if not isinstance(value, (list, tuple)):
            raise InputError(f"{where}: {field}: expected a list, got {short(value)}")
        inner = args[0] if args else Any
        return [_convert(inner, v, where, f"{field}[{i}]") for i, v in enumerate(value)]
    if origin is dict or tp is dict:
        if not isinstance(value, Mapping):
            raise InputError(f"{where}: {field}: expected a mapping, got {short(value)}")
        return dict(value)
    if typing.get_origin(tp) is typing.Literal:
        if value not in args:
            raise InputError(f"{where}: {field}: expected one of {list(args)}, got {short(value)}")
        return value
    return value


def _field_default(f: dataclasses.Field, base: Any) -> Any:
    """The value field `f` takes when the YAML leaves it out: base's, else the field's default."""
    if base is not None:
        return getattr(base, f.name)
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return f.default


def from_dict(cls: type, data: Mapping[str, Any] | None, where: str = "<config>", prefix: str = "",
              base: Any = None):
    """Build dataclass `cls` from `data`, defaults for missing keys, unknown keys rejected.

    where: the file (or other source) named in errors; prefix: the dotted path of `cls`
    inside that file; base: an instance of cls whose values stand in for missing keys (None:
    the field defaults). A nested block keeps the values of its parent's default for the keys
    it does not name, so a partial `ceres_scan_matcher:` block changes only what it names.
    Raises InputError("pf.yaml: motion.srr: expected a number, got 'x'").
    """
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise InputError(f"{where}: {prefix.rstrip('.') or 'top level'}: expected a mapping, got {short(data)}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    kwargs = {}
    for key, value in data.items():
        if key not in fields:
            raise InputError(f"{where}: {prefix}{key}: unknown key{_suggest(str(key), sorted(fields))}")
        default = _field_default(fields[key], base)
        if (isinstance(value, Mapping) and dataclasses.is_dataclass(default)
                and not isinstance(default, type)):
            kwargs[key] = from_dict(type(default), value, where, f"{prefix}{key}.", base=default)
        else:
            kwargs[key] = _convert(hints[key], value, where, f"{prefix}{key}")
    try:
        return cls(**kwargs) if base is None else dataclasses.replace(base, **kwargs)
    except InputError:
        raise
    except (TypeError, ValueError) as err:
        raise InputError(f"{where}: {prefix.rstrip('.') or 'config'}: {err}") from None


def to_dict(obj: Any) -> Any:
    """Plain YAML-ready data of a (nested) dataclass: tuples become lists."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_dict(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [to_dict(v) for v in obj]
    if isinstance(obj, dict):
        return {k: to_dict(v) for k, v in obj.items()}
    if hasattr(obj, "item") and callable(obj.item):  # numpy scalar
        return obj.item()
    return obj


def set_override(data: dict, override: str) -> dict:
    """Apply one command-line override `key.path=value` to nested plain data, in place: the
    value is read as YAML (`1e5`, `true`, `[1, 2]`), missing levels are created. Returns data."""
    if "=" not in override:
        raise InputError(f"override {short(override)}: expected key.path=value")
    key, value = override.split("=", 1)
    return set_dotted(data, key.strip(), parse_yaml(value, f"override {short(override)}"),
                      f"override {short(override)}")


def set_dotted(data: dict, path: str, value: Any, where: str = "<config>") -> dict:
    """Set `value` at the dotted `path` of nested plain data, in place, creating missing
    levels; InputError (naming `where`) when a level on the way holds a value. Returns data."""
    parts = path.split(".")
    d = data
    for i, p in enumerate(parts[:-1]):
        d = d.setdefault(p, {})
        if not isinstance(d, dict):
            raise InputError(f"{where}: {'.'.join(parts[:i + 1])} holds a value, not a block "
                             "of fields")
    d[parts[-1]] = value
    return data


def dump_yaml(data: Any) -> str:
    """YAML text of plain data or a dataclass, keys in definition order."""
    return yaml.safe_dump(to_dict(data), sort_keys=False, default_flow_style=None)


def atomic_write_bytes(path: str | os.PathLike, data: bytes,
                       root: str | os.PathLike | None = None) -> None:
    """Write `data` to `path` via a temporary file and rename: never a half-written file.

    root: the folder the file belongs to; a `path` that resolves outside it (a name holding
    `..`, an absolute path, a symlink out) raises InputError and writes nothing.
    An OSError names `path` (not the temporary file; a full disk names no file at all).
    """
    p = Path(path)
    if root is not None:
        from worlds.paths import path_inside
        p = path_inside(root, p.absolute())
    try:
        _write_and_rename(p, data)
    except OSError as err:
        if err.errno is None:
            raise
        raise OSError(err.errno, err.strerror, str(p)) from err


def _write_and_rename(p: Path, data: bytes) -> None:
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        # mkstemp creates 0600; give the file the mode a plain open() would (0666 & ~umask)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, p)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def atomic_write_text(path: str | os.PathLike, text: str,
                      root: str | os.PathLike | None = None) -> None:
    """Atomic text write (UTF-8), see atomic_write_bytes."""
    atomic_write_bytes(path, text.encode("utf-8"), root)
