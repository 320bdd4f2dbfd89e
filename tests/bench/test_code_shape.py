"""The shape of bench's code: no function over 60 lines, and no algorithm named in it (what an
algorithm is, the benchmark reads from its class: slam.base.Slam's describing attributes)."""
import ast
from pathlib import Path

import pytest

from slam import registry

BENCH = Path(__file__).resolve().parents[2] / "bench"
MODULES = sorted(BENCH.glob("*.py"))
MAX_LINES = 60


def _long_functions(tree: ast.Module) -> list[str]:
    return [f"{node.lineno} {node.name}: {node.end_lineno - node.lineno + 1} lines"
            for node in ast.walk(tree) if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > MAX_LINES]


def _algorithm_strings(tree: ast.Module) -> list[str]:
    """String constants (f-string parts too) that are a shipped algorithm's name."""
    names = set(registry.BUILTIN)
    return [f"{node.lineno} {node.value!r}" for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and node.value.strip() in names]


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_no_function_is_over_60_lines(path):
    assert not _long_functions(ast.parse(path.read_text(), filename=str(path)))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_no_algorithm_name_is_a_string_in_bench(path):
    assert not _algorithm_strings(ast.parse(path.read_text(), filename=str(path)))


def test_the_checks_find_what_they_look_for():
    body = "    x = 1\n" * (MAX_LINES - 2)
    assert not _long_functions(ast.parse(f"def f():\n{body}    return x\n"))
    assert _long_functions(ast.parse(f"def f():\n{body}    x += 1\n    return x\n"))
    for code in ('a == "oracle"', "x = ['pf', 'gn']", 'f"{x}graph"', '{"graph": 8.0}'):
        assert _algorithm_strings(ast.parse(code)), code
    assert not _algorithm_strings(ast.parse('"pf, gn, graph"; "oracle (ceiling)"; pf = 1'))
