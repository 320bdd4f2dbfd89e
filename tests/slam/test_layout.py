"""The shape of slam/: every algorithm a package of the same shape behind one contract, no
algorithm importing another, no cycles, short update() methods, no code repeated between two
algorithms, no config field that nothing uses, and config tables in docs/ in sync."""
from __future__ import annotations

import ast
import dataclasses
import inspect
from pathlib import Path

import pytest

from slam import registry
from slam.base import Slam
from slam.fields import config_fields, with_field_table

ROOT = Path(__file__).resolve().parents[2]
SLAM = ROOT / "slam"
ALGORITHM_PACKAGES = sorted(target.split(":")[0] for target in registry.BUILTIN.values())
PACKAGE_FILES = ("__init__.py", "slam.py", "config.py")


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in SLAM.rglob("*.py")}


def _imports(path: Path, known: set[str]) -> set[str]:
    """slam modules imported anywhere in the file (a `from pkg import name` naming a submodule
    counts as that submodule)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        else:
            continue
        out.update(n for n in names if n in known)
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    return {m: _imports(p, set(mods)) - {m} for m, p in mods.items()}


def _package_of(module: str) -> str | None:
    return next((p for p in ALGORITHM_PACKAGES if module == p or module.startswith(p + ".")), None)


def test_every_builtin_algorithm_is_a_package_of_the_same_shape():
    for pkg in ALGORITHM_PACKAGES:
        folder = ROOT / pkg.replace(".", "/")
        assert folder.is_dir(), pkg
        for name in PACKAGE_FILES:
            assert (folder / name).is_file(), f"{pkg}: no {name}"
    for name, cls in registry.algorithms().items():
        assert issubclass(cls, Slam) and cls.name == name


def test_import_graph_has_no_cycle():
    """(No algorithm importing another, and the layering, are import-linter contracts:
    tests/test_imports.py.)"""
    graph = _graph()
    state: dict[str, int] = {}

    def visit(m, stack):
        state[m] = 1
        for d in graph[m]:
            if state.get(d) == 1:
                raise AssertionError("import cycle: " + " -> ".join(stack + [m, d]))
            if d not in state:
                visit(d, stack + [m])
        state[m] = 2

    for m in graph:
        if m not in state:
            visit(m, [])


def test_the_import_parser_finds_nested_and_from_imports(tmp_path):
    """The import parser finds nested and from-imports (so the test above can fail)."""
    p = tmp_path / "m.py"
    p.write_text("def f():\n    from slam.gn import slam as s\n    import slam.pf.maps\n")
    assert _imports(p, {"slam.gn", "slam.gn.slam", "slam.pf.maps"}) == {"slam.gn", "slam.gn.slam", "slam.pf.maps"}


@pytest.mark.parametrize("name", list(registry.BUILTIN))
def test_update_is_at_most_30_lines(name):
    lines, _ = inspect.getsourcelines(registry.get(name).update)
    assert len(lines) <= 30, f"{name}.update() has {len(lines)} lines"


def _normalized_lines(path: Path) -> list[str]:
    """Code lines without blanks, comments and docstrings, whitespace-normalized."""
    tree = ast.parse(path.read_text())
    doc_lines = set()
    for node in ast.walk(tree):
        if (isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef)) and node.body
                and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)
                and isinstance(node.body[0].value.value, str)):
            doc_lines.update(range(node.body[0].lineno, node.body[0].end_lineno + 1))
    out = []
    for i, line in enumerate(path.read_text().splitlines(), start=1):
        s = " ".join(line.split("#", 1)[0].split())
        if s and i not in doc_lines and not s.startswith(("import ", "from ")):
            out.append(s)
    return out


def repeated_blocks(files_a: list[Path], files_b: list[Path], size: int = 6) -> list[tuple]:
    """(file a, file b, first line) of every block of `size` normalized lines found in both sets."""
    def windows(files):
        out = {}
        for f in files:
            lines = _normalized_lines(f)
            for k in range(len(lines) - size + 1):
                out.setdefault("\n".join(lines[k:k + size]), (f, lines[k]))
        return out
    wa, wb = windows(files_a), windows(files_b)
    return [(wa[k][0].name, wb[k][0].name, wa[k][1]) for k in wa.keys() & wb.keys()]


def test_no_block_of_six_lines_is_repeated_between_two_algorithms():
    files = {p: sorted((ROOT / p.replace(".", "/")).rglob("*.py")) for p in ALGORITHM_PACKAGES}
    found = []
    for i, a in enumerate(ALGORITHM_PACKAGES):
        for b in ALGORITHM_PACKAGES[i + 1:]:
            found += repeated_blocks(files[a], files[b])
    assert not found, found


def test_the_duplicate_finder_finds_a_copied_block(tmp_path):
    src = "\n".join(f"x{i} = compute({i}, y)  # step {i}" for i in range(8))
    (tmp_path / "a.py").write_text("def f(y):\n" + "\n".join("    " + s for s in src.splitlines()))
    (tmp_path / "b.py").write_text("# other\n" + src + "\n")
    assert repeated_blocks([tmp_path / "a.py"], [tmp_path / "b.py"])


def _attributes_read() -> set[str]:
    """Attribute names read anywhere in slam/ outside __post_init__ (validation is no use)."""
    names = set()
    for p in SLAM.rglob("*.py"):
        tree = ast.parse(p.read_text())
        skip = {id(n) for f in ast.walk(tree) if isinstance(f, ast.FunctionDef)
                and f.name == "__post_init__" for n in ast.walk(f)}
        names.update(n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and id(n) not in skip)
    return names


def _owner(cls: type, dotted: str):
    for part in dotted.split(".")[:-1]:
        cls = type(getattr(cls(), part))
    name = dotted.split(".")[-1]
    return next(k for k in cls.__mro__ if name in getattr(k, "__annotations__", {})), name


def unused_config_fields() -> list[str]:
    """Fields that no code reads, and switches (bool or str fields) that take one value in every
    default and shipped config and in what every sensor class derives (the other side of the
    switch is dead code)."""
    from slam.sensors import apply_derived
    from tests.slam.sensor_classes import CLASSES
    read = _attributes_read()
    values: dict[tuple, set] = {}
    paths: dict[tuple, list] = {}
    for name, cls in registry.algorithms().items():
        if _package_of(cls.__module__) is None:
            continue
        cfgs = [cls.config_class()] + [apply_derived(cls.config_class(), cls.derive_config(f))
                                       for f in CLASSES]
        for y in sorted((SLAM / "configs").glob("*.yaml")):
            try:
                cfgs.append(registry.load_config(name, y))
            except Exception:
                continue      # another algorithm's config
        for row in config_fields(cls.config_class):
            key = _owner(cls.config_class, row.path)
            paths.setdefault(key, []).append(f"{name}: {row.path}")
            for c in cfgs:
                obj = c
                for part in row.path.split("."):
                    obj = getattr(obj, part)
                values.setdefault(key, set()).add(repr(obj))
    unused = []
    for (owner, field), vals in values.items():
        switch = all(v in ("True", "False") or v.startswith("'") for v in vals)
        if field not in read or (switch and len(vals) < 2):
            unused += paths[(owner, field)]
    return sorted(unused)


def test_every_config_field_is_used():
    assert unused_config_fields() == []


def test_the_unused_field_check_flags_a_switch_nothing_turns(monkeypatch):
    from slam.oracle.config import OracleConfig

    @dataclasses.dataclass(frozen=True)
    class WithSwitch(OracleConfig):
        fancy_mode: bool = False        # read by nothing, turned by no config

    monkeypatch.setattr(registry.get("oracle"), "config_class", WithSwitch)
    assert "oracle: fancy_mode" in unused_config_fields()


@pytest.mark.parametrize("name", list(registry.BUILTIN))
def test_docs_field_table_is_in_sync(name):
    page = ROOT / "docs" / "algorithms" / f"{name}.md"
    text = page.read_text()
    cls = registry.get(name).config_class
    assert with_field_table(text, cls) == text, (
        f"{page.relative_to(ROOT)} is out of date: python -m slam fields {name} --update {page.relative_to(ROOT)}")
    assert all(r.doc for r in config_fields(cls)), "a config field without its comment"
