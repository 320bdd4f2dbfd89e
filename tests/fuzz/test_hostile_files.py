"""Hostile files, round two (issue 38): random world YAML, suite YAML and run folders
(results.json, run.json) built around valid ones, with the shapes that once took gigabytes,
hung, wrote outside the output folder or ended in a traceback: YAML alias bombs, circles of
10^8 sides, thousands of obstacles, names that are paths, 1e308 / nan / inf coordinates,
100,000-deep nesting, huge strings, binary files, wrong-typed rows.

Each example runs its command line in a forked child (tests/fuzz/forked.py) and must end
within 60 s with exit code 0 or 2; stderr at most one line (`error: ...` naming the file when
the code is 2, at most 1,000 characters), no traceback and no Python warning; peak resident
memory under 1 GB (as a process of its own would have it: tests/fuzz/forked.py); no file
written, changed or removed outside the output folder (the log cache, elsewhere, is allowed);
and a results.json or run.json the command rewrote reads back. Suite and resume examples are
always invalid in at least one field (bench has no dry run): a SLAM run that starts anyway is
reported by a guard. The issue's own cases also run once each (test_known_*).
Shrinking is off: a hang would cost 60 s per step; the failure message prints the input."""
from __future__ import annotations

import copy
import functools
import json
import math
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings, strategies as st

import bench.add  # noqa: F401  (imported before the fork: each example then costs a fork only)
import bench.figures  # noqa: F401
import bench.merge  # noqa: F401
import bench.report  # noqa: F401
import bench.runner
import bench.suite  # noqa: F401
import worlds.generate  # noqa: F401
import worlds.raster  # noqa: F401
from bench.__main__ import main as bench_main
from bench.results import RESULTS_NAME, RUN_NAME, read_rows, read_run
from tests.fuzz.forked import changed_outside, import_baseline_kb, listing, run_forked
from worlds.__main__ import main as worlds_main
from worlds.yamlio import InputError

TINY = Path(__file__).resolve().parents[1] / "bench" / "tiny_world.yaml"
TIMEOUT_S = 60.0
MAX_PEAK_KB = 1024 * 1024
MAX_LINE = 1000


def _fuzz(examples: int):
    return settings(max_examples=examples, deadline=None, derandomize=True,
                    phases=[Phase.explicit, Phase.generate],
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.large_base_example])


# --- YAML text with hostile parts ---------------------------------------------------------

class Raw(str):
    """YAML written as is: an alias bomb, deep nesting, a number in a form of its own."""


def _key(k) -> str:
    return k if isinstance(k, str) and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", k) else _flow(k)


def _flow(v) -> str:
    """Flow-style YAML of plain data with Raw parts."""
    if isinstance(v, Raw):
        return str(v)
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return ".nan"
        if math.isinf(v):
            return ".inf" if v > 0 else "-.inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_flow(x) for x in v) + "]"
    return "{" + ", ".join(f"{_key(k)}: {_flow(x)}" for k, x in v.items()) + "}"


def _yaml(data) -> str:
    """A block mapping of flow values (as the shipped files are written), else one flow value."""
    if isinstance(data, dict) and not isinstance(data, Raw):
        return "".join(f"{_key(k)}: {_flow(v)}\n" for k, v in data.items())
    return _flow(data) + "\n"


def _alias_bomb(levels: int, width: int) -> Raw:
    """levels x width: `[&a0 [lol, ...], &a1 [*a0, *a0, ...], ...]`, width**levels leaves."""
    rows = ["&a0 [" + ", ".join(["lol"] * width) + "]"]
    rows += [f"&a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]" for i in range(1, levels)]
    return Raw("[" + ", ".join(rows) + "]")


def _deep(n: int, mapping: bool) -> Raw:
    return Raw("{a: " * n + "1" + "}" * n) if mapping else Raw("[" * n + "]" * n)


BOMBS = st.one_of(st.builds(_alias_bomb, st.sampled_from([2, 5, 9]), st.sampled_from([2, 9])),
                  st.sampled_from([Raw('&a "text"'), Raw("&a 0.05"), Raw("*a"),
                                   Raw("{<<: {b: 1}, c: 2}")]))
DEEP = st.builds(_deep, st.sampled_from([63, 64, 65, 101, 1000, 100_000]), st.booleans())
NUMBERS = [1e308, -1e308, math.nan, math.inf, -math.inf, 1e6, 1e6 + 1, 1e-300, 0, -0.0, 2**64,
           Raw("1e5"), Raw("5e-2"), Raw("-1E+3"), Raw("1e400"), Raw(".5e1"), Raw("0x10"),
           Raw("1_000"), Raw("1:30"), Raw("9" * 5000), True, None, "x", [], {}]
TAGS = [Raw("!!python/object/apply:os.system ['touch pwned']"), Raw("!!python/name:os.system"),
        Raw("!!binary aGVsbG8="), Raw("!!set {a, b}"), Raw("2001-12-14"), Raw("!custom x"),
        Raw("!!float x"), Raw("!!int 1.5"), Raw("!!omap [a: 1]")]
JSONISH = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
                       lambda inner: st.lists(inner, max_size=4)
                       | st.dictionaries(st.text(max_size=6), inner, max_size=4), max_leaves=12)


def _names(box: Path) -> list[str]:
    """Names that must not become paths, and some that may."""
    return ["../x", "../../x", "../victim", "../../../../victim", str(box / "abs" / "x"),
            str(box / "victim"), "a/b", "..", ".", "", " ", "ünïcødé", "名前", "x" * 101,
            ".hidden", "a b", "a\\b", "a\0b", "~", "$HOME", "room\n", "x" * 100, "-", "room"]


def _paths(node, pred, prefix=()) -> list[tuple]:
    """Paths (keys and indices) of the nodes under `node` for which pred holds."""
    out = [prefix] if pred(node) else []
    if isinstance(node, dict) and not isinstance(node, Raw):
        for k, v in node.items():
            out += _paths(v, pred, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, pred, prefix + (i,))
    return out


def _put(node, path: tuple, value) -> None:
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value


def _pick(draw, items: list):
    return items[draw(st.integers(0, len(items) - 1))]


def _list(v) -> list:
    """v if it is a list (not what an earlier mutation put there), else []."""
    return v if isinstance(v, list) else []


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


# --- world YAML ---------------------------------------------------------------------------

BASE_WORLD = {
    "name": "room",
    "description": "a 3 m x 2 m room with a box",
    "resolution": 0.05,
    "walls": {"thickness": 0.1, "polylines": [[[0, 0], [3, 0], [3, 2], [0, 2], [0, 0]]]},
    "obstacles": [{"box": {"center": [1.5, 1.0], "size": [0.3, 0.3], "yaw": 0.2}}],
    "robot": {"start": [0.6, 0.6, 0.0]},
    "route": [[2.4, 0.6]],
}


def _w_name(draw, w, box):
    w["name"] = draw(st.sampled_from(_names(box)))
    return f"name {w['name'][:40]!r}"


def _w_bomb(draw, w, box):
    field = draw(st.sampled_from(["description", "resolution", "name", "obstacles", "route"]))
    w[field] = draw(BOMBS)
    return f"{field}: {w[field][:60]}"


def _w_circle(draw, w, box):
    sides = draw(st.sampled_from([100_000_000, 361, 360, 8, 7, 0, -1, Raw("1e8"), 1.5, "x", 2**64,
                                  Raw("9" * 5000)]))
    w["obstacles"] = _list(w.get("obstacles")) + [{"circle": {"center": [1.0, 1.5], "radius": 0.2,
                                                              "sides": sides}}]
    return f"circle sides {str(sides)[:20]}"


def _w_many_obstacles(draw, w, box):
    n = draw(st.sampled_from([2001, 1999, 2000]))
    kind = draw(st.sampled_from(["circle", "box", "polygon"]))
    rng = np.random.default_rng(draw(st.integers(0, 9)))
    xy = np.round(np.column_stack([rng.uniform(1.0, 2.0, n), rng.uniform(1.3, 1.8, n)]), 3).tolist()
    if kind == "box":
        items = [{"box": {"center": c, "size": [0.02, 0.02]}} for c in xy]
    elif kind == "circle":
        sides = draw(st.sampled_from([360, 8]))
        items = [{"circle": {"center": c, "radius": 0.01, "sides": sides}} for c in xy]
    else:
        items = [{"polygon": [[x, y], [x + 0.02, y], [x, y + 0.02]]} for x, y in xy]
    w["obstacles"] = _list(w.get("obstacles")) + items
    return f"{n} {kind} obstacles"


def _w_number(draw, w, box):
    spots = _paths(w, _is_number)
    if not spots:
        return "no number to replace"
    path = _pick(draw, spots)
    value = draw(st.sampled_from(NUMBERS))
    _put(w, path, value)
    return f"{'.'.join(map(str, path))} = {str(value)[:20]}"


def _w_scale(draw, w, box):
    """Every coordinate scaled or shifted: a far-away or a huge world (maybe valid)."""
    op = draw(st.sampled_from(["scale", "shift"]))
    k = draw(st.sampled_from([1e5, 1e300, 2.0] if op == "scale" else [999_990.0, 2e6, -5e5]))
    for key in ("walls", "obstacles", "robot", "route"):
        if key in w:
            for path in _paths(w[key], _is_number):
                if path and path[-1] in ("yaw", "thickness", "radius", "sides") or \
                        (key == "robot" and path[-1] == 2):
                    continue
                node = w[key]
                for p in path[:-1]:
                    node = node[p]
                node[path[-1]] = node[path[-1]] * k if op == "scale" else node[path[-1]] + k
    return f"coordinates {op} {k:g}"


def _w_extent(draw, w, box):
    """Walls around a large area, or a tiny cell: many cells (under and over the cap)."""
    choice = draw(st.sampled_from(["room", "cell"]))
    if choice == "room":
        side = draw(st.sampled_from([300.0, 400.0, 2000.0, 100.0]))
        w["walls"] = {"thickness": 0.1,
                      "polylines": [[[0, 0], [side, 0], [side, side], [0, side], [0, 0]]]}
        return f"{side:g} m square room"
    w["resolution"] = draw(st.sampled_from([Raw("1e-4"), 1e-300, 100.0, 101.0, Raw("5e-3")]))
    return f"resolution {w['resolution']}"


def _w_many_points(draw, w, box):
    n = draw(st.sampled_from([20_001, 5_000]))
    where = draw(st.sampled_from(["walls", "route"]))
    rng = np.random.default_rng(n)
    if where == "walls":
        xs = np.linspace(0.0, 3.0, n).round(4)
        w["walls"] = w["walls"] if isinstance(w.get("walls"), dict) else {}
        w["walls"]["polylines"] = [[[float(x), 0.0] for x in xs] + [[3, 2], [0, 2], [0, 0]]]
    else:
        w["route"] = np.round(np.column_stack([rng.uniform(2.3, 2.5, n), rng.uniform(0.5, 0.7, n)]),
                              3).tolist()
    return f"{n} points in {where}"


def _w_deep(draw, w, box):
    spots = _paths(w, lambda v: True)[1:]
    path = _pick(draw, spots)
    _put(w, path, draw(DEEP))
    return f"{'.'.join(map(str, path))} nested deep"


def _w_huge(draw, w, box):
    n = draw(st.sampled_from([3_900_000, 4_200_000, 1_000_000, 10_000]))
    field = draw(st.sampled_from(["description", "name", "key"]))
    if field == "key":
        w["k" * n] = 1
    else:
        w[field] = "x" * n
    return f"{field} of {n:,} characters"


def _w_structure(draw, w, box):
    op = draw(st.sampled_from(["delete", "unknown", "replace", "wrap"]))
    spots = _paths(w, lambda v: True)[1:]
    path = _pick(draw, spots)
    parent = w
    for p in path[:-1]:
        parent = parent[p]
    if op == "delete":
        del parent[path[-1]]
    elif op == "unknown":
        target = parent if isinstance(parent, dict) else w
        target[draw(st.sampled_from(["nmae", "obstacle", "goal", "", "<<", "../x"]))] = 1
    elif op == "replace":
        parent[path[-1]] = draw(JSONISH)
    else:
        parent[path[-1]] = [parent[path[-1]]]
    return f"{op} {'.'.join(map(str, path))}"


def _w_tag(draw, w, box):
    spots = _paths(w, lambda v: True)[1:]
    path = _pick(draw, spots)
    _put(w, path, draw(st.sampled_from(TAGS)))
    return f"{'.'.join(map(str, path))} tagged"


def _w_file(draw, w, box):
    """The whole file one hostile shape (then the mapping built so far is not written)."""
    w["@file"] = draw(st.sampled_from(["bytes", "bom", "crlf", "tabs", "latin-1", "nul", "top"]))
    return f"file {w['@file']}"


# quick to write and to refuse: many examples of each
WORLD_MUTATIONS = {"name": _w_name, "bomb": _w_bomb, "circle": _w_circle, "number": _w_number,
                   "deep": _w_deep, "structure": _w_structure, "tag": _w_tag, "file": _w_file}
# files of up to 4 MB and worlds that are valid but large: a few examples of each
LARGE_WORLD_MUTATIONS = {"obstacles": _w_many_obstacles, "points": _w_many_points,
                         "extent": _w_extent, "huge": _w_huge, "scale": _w_scale}


def _encode(draw, w: dict) -> bytes:
    """The YAML's bytes, or the whole-file hostile shape _w_file chose."""
    form = w.pop("@file", "utf-8")
    text = _yaml(w)
    if form == "bom":
        return ("\ufeff" + text).encode()
    if form == "crlf":
        return text.replace("\n", "\r\n").encode()
    if form == "tabs":
        return text.replace("\n", "\n\t", 2).encode()
    if form == "latin-1":
        return text.encode() + b"description: \xe9t\xe9\n"
    if form == "nul":
        return text.encode().replace(b":", b"\0:", 1)
    if form == "top":
        top = draw(st.sampled_from([_deep(100_000, False), _alias_bomb(9, 9), Raw("[]"), Raw("~"),
                                    Raw(""), Raw("- a\n- b"), Raw("? [a, b]\n: 1")]))
        return (str(top) + "\n").encode()
    if form == "bytes":
        return draw(st.binary(max_size=300))
    return text.encode()


def hostile_world(draw, box: Path, kind: str | None = None) -> tuple[bytes, str]:
    """A world file's bytes and a label of what was done to it: the mutation `kind` (default:
    a quick one drawn), then up to two more quick ones."""
    w = copy.deepcopy(BASE_WORLD)
    first = {**WORLD_MUTATIONS, **LARGE_WORLD_MUTATIONS}[kind] if kind else \
        draw(st.sampled_from(list(WORLD_MUTATIONS.values())))
    more = draw(st.lists(st.sampled_from(list(WORLD_MUTATIONS.values())), max_size=2))
    labels = [m(draw, w, box) for m in [first, *more]]
    return _encode(draw, w), "; ".join(labels)


# --- running and checking -----------------------------------------------------------------

def _sandbox(tmp_path: Path) -> tuple[Path, Path]:
    """A fresh box: in/ (inputs), cwd/ (the child's folder), d1/d2/d3/out (the output, four
    levels down so that `../../../../x` still lands inside the box) and victim.yaml files
    where escaping names would write. Returns (box, out)."""
    box = tmp_path / "box"
    shutil.rmtree(box, ignore_errors=True)
    out_parent = box / "d1" / "d2" / "d3"
    for d in (box / "in", box / "cwd", out_parent):
        d.mkdir(parents=True)
    for d in (box, box / "d1", box / "d1" / "d2", out_parent):
        (d / "victim.yaml").write_text("name: victim\n")
    return box, out_parent / "out"


def _no_run():
    """Installed in the child: a SLAM run that starts is an error (bench has no dry run)."""
    def refuse(*args, **kwargs):
        raise RuntimeError("fuzz guard: the input was meant to be invalid, yet a run started")
    bench.runner.make_executor = refuse


@functools.cache
def _base_kb() -> int:
    """What a fresh interpreter holds after importing what this module imports (kB)."""
    return import_baseline_kb(["bench.__main__", "bench.add", "bench.figures", "bench.merge",
                               "bench.report", "bench.runner", "bench.suite", "worlds.__main__",
                               "worlds.generate", "worlds.raster"])


def _run_files(dirs: tuple[Path, ...]) -> dict[Path, bytes | None]:
    return {d / n: (d / n).read_bytes() if (d / n).is_file() else None
            for d in dirs for n in (RESULTS_NAME, RUN_NAME)}


def _unreadable(path: Path) -> str:
    """'' when results.json / run.json at `path` reads back, else the reader's complaint."""
    try:
        read_rows(path) if path.name == RESULTS_NAME else read_run(path.parent)
    except InputError as err:
        return str(err)
    return ""


def _check(main, argv: list[str], tmp_path: Path, box: Path, outs: tuple[Path, ...],
           named: tuple[str, ...], label: str, guards=None, run_dirs: tuple[Path, ...] = ()) -> None:
    """Run main(argv) in a forked child and assert the contract of the module docstring.
    outs: the folders it may write; named: strings of which the error line names one;
    run_dirs: run folders whose results.json and run.json, when the command rewrites them,
    must read back (a command never leaves a file its own readers refuse)."""
    before = listing(tmp_path, skip=outs)
    files = _run_files(run_dirs)
    o = run_forked(main, argv, box / "cwd", timeout_s=TIMEOUT_S, max_peak_kb=MAX_PEAK_KB,
                   base_kb=_base_kb(), guards=guards)
    after = listing(tmp_path, skip=outs)
    lines = o.err_lines
    ctx = (f"\ninput: {label}\nargv: {argv}\nexit {o.code!r} after {o.seconds:.1f} s, peak "
           f"{o.peak_kb:,} kB\nstderr ({len(o.err):,} characters): {o.err[:3000]}")
    assert not o.killed, f"killed: {o.killed}{ctx}"
    assert "Traceback" not in o.err, f"traceback{ctx}"
    assert o.code in (0, 2), f"exit code {o.code!r}{ctx}"
    assert not re.search(r"\w+Warning\b", o.err), f"a warning on stderr{ctx}"
    assert len(lines) <= 1, f"{len(lines)} lines on stderr{ctx}"
    assert all(len(line) <= MAX_LINE for line in lines), f"a line over {MAX_LINE} characters{ctx}"
    if o.code == 2:
        assert lines and lines[0].startswith("error: "), f"exit 2 without an error line{ctx}"
        assert any(n in lines[0] for n in named), f"the error names none of {named}{ctx}"
    assert o.peak_kb < MAX_PEAK_KB, f"peak memory {o.peak_kb:,} kB{ctx}"
    changed = changed_outside(before, after)
    assert not changed, f"written outside the output folder: {changed[:10]}{ctx}"
    for path, data in _run_files(run_dirs).items():
        if data is not None and data != files[path]:
            problem = _unreadable(path)
            assert not problem, f"{path.name} written and then refused: {problem}{ctx}"


@pytest.fixture(scope="module", autouse=True)
def log_cache(tmp_path_factory):
    """A private log cache (generated suite worlds and logs go there), for the module."""
    with pytest.MonkeyPatch.context() as mp:
        d = tmp_path_factory.mktemp("cache")
        mp.setenv("SLAM_BENCH_CACHE", str(d))
        yield d


def _render(tmp_path: Path, data, kind: str) -> None:
    box, out = _sandbox(tmp_path)
    raw, label = hostile_world(data.draw, box, kind)
    f = box / "in" / "w.yaml"
    f.write_bytes(raw)
    extra = data.draw(st.sampled_from([[]] * 6 + [["--png"], ["--image-format", "png"],
                                                  ["--resolution", "1e-5"], ["--resolution", "0.5"]]))
    _check(worlds_main, ["render", str(f), "--out", str(out), *extra], tmp_path, box, (out,),
           (str(f), "--resolution"), f"world YAML: {label} ({len(raw):,} bytes): {raw[:300]!r}")


@pytest.mark.parametrize("kind", sorted(WORLD_MUTATIONS))
@_fuzz(30)
@given(data=st.data())
def test_world_yaml(tmp_path, kind, data):
    _render(tmp_path, data, kind)


@pytest.mark.parametrize("kind", sorted(LARGE_WORLD_MUTATIONS))
@_fuzz(6)
@given(data=st.data())
def test_large_world_yaml(tmp_path, kind, data):
    _render(tmp_path, data, kind)


def _exponent_form(v: float, style: str) -> Raw:
    """v in exponent form, most of them forms plain YAML 1.1 reads as strings (no dot, or no
    sign on the exponent): 2.4 -> 24e-1, 24E-1, 24e-01, +24e-1, 2.4e0."""
    from decimal import Decimal
    sign, digits, exp = Decimal(repr(float(v))).normalize().as_tuple()
    m = ("-" if sign else "") + "".join(map(str, digits))
    if style == "dot":
        return Raw(f"{m[:-1] or 0}.{m[-1]}e{exp + 1}" if len(digits) > 1 else f"{m}.0e{exp}")
    return Raw({"e": f"{m}e{exp}", "E": f"{m}E{exp}", "0": f"{m}e{exp:+03d}",
                "+": f"+{m}e{exp}" if not sign else f"{m}e{exp}"}[style])


@_fuzz(20)
@given(data=st.data())
def test_world_yaml_exponent_numbers_are_numbers(tmp_path, data):
    """A valid world with numbers written as 1e5 and 5e-2 is the plain one: exit 0, same map."""
    box, out = _sandbox(tmp_path)
    style = data.draw(st.sampled_from(["e", "E", "0", "+", "dot"]))
    w = copy.deepcopy(BASE_WORLD)
    for path in _paths(w, _is_number):
        if data.draw(st.booleans()):
            _put(w, path, _exponent_form(_get(w, path), style))
    f = box / "in" / "room.yaml"
    f.write_text(_yaml(w))
    o = run_forked(worlds_main, ["render", str(f), "--out", str(out)], box / "cwd")
    assert (o.code, o.err) == (0, ""), (_yaml(w), o)
    plain = tmp_path / "plain"
    if not plain.exists():
        (tmp_path / "plain.yaml").write_text(_yaml(BASE_WORLD))
        assert run_forked(worlds_main, ["render", str(tmp_path / "plain.yaml"), "--out", str(plain)],
                          box / "cwd").code == 0
    assert (out / "room.pgm").read_bytes() == (plain / "room.pgm").read_bytes()
    assert (out / "room.yaml").read_text() == (plain / "room.yaml").read_text()


def _get(node, path):
    for p in path:
        node = node[p]
    return node


# --- suite YAML ---------------------------------------------------------------------------

SHIPPED = ["rectangle_s", "corridor", "loop", "swirl_s"]
# generated worlds that are valid and quick to draw (each is drawn once into the cache)
CHEAP_GENERATED = [{"generate": "hall", "seed": 0, "size": [4, 3]},
                   {"generate": "loop", "seed": 0, "size": [4.5, 4]}]


def _bad_generated(draw) -> dict:
    """A {generate, seed, size} entry wrong in exactly one part (so it is never drawn)."""
    item = copy.deepcopy(draw(st.sampled_from(CHEAP_GENERATED)))
    part = draw(st.sampled_from(["generate", "seed", "size", "key", "missing"]))
    if part == "generate":
        item["generate"] = draw(st.sampled_from(["nope", 5, None, "../x", "", "HALL", []]))
    elif part == "seed":
        item["seed"] = draw(st.sampled_from([-1, "x", 1.5, True, Raw("1e3"), None, [0]]))
    elif part == "size":
        item["size"] = draw(st.sampled_from([
            [100_000, 100_000], [1e308, 1], [math.nan, 1], [math.inf, 1], [0, 0], [-1, 5], [1, 1000],
            [40, 40], "10x8", [10], [10, 8, 1], [True, 1], ["4", "3"], Raw("[1e5, 1e5]"), {}]))
    elif part == "key":
        item[draw(st.sampled_from(["sizes", "kind", "", "../x"]))] = 1
    else:
        del item["generate"]
    return item


def _bad_world_entry(draw, box: Path):
    """A `worlds:` entry that is refused: no such world, not a file, a bad generated one."""
    if draw(st.booleans()):
        return _bad_generated(draw)
    return draw(st.sampled_from([
        "no_such_world", "rectangle_s.yml", "../nope.yaml", "/dev/zero", "/dev/urandom",
        str(box / "in" / "fifo.yaml"), str(box / "d1"), "d1/", 5, None, [], "", "   ", "名前",
        _alias_bomb(9, 9)]))


def _any_world_entry(draw, box: Path):
    """A `worlds:` entry, valid or not; files name the hostile world written beside the suite."""
    kind = draw(st.sampled_from(["shipped", "generated", "file", "bad"]))
    if kind == "shipped":
        return draw(st.sampled_from(SHIPPED))
    if kind == "generated":
        return copy.deepcopy(draw(st.sampled_from(CHEAP_GENERATED)))
    if kind == "file":
        return draw(st.sampled_from(["w.yaml", str(box / "in" / "w.yaml"), "../in/w.yaml"]))
    return _bad_world_entry(draw, box)


def hostile_suite(draw, box: Path) -> tuple[str, str]:
    """A suite file's text and a label: unusual but valid values everywhere, then one field
    made invalid (the last world entry most often, so that the entries before it are read,
    generated worlds drawn and world files loaded): a valid suite would start a real run."""
    bad = draw(st.sampled_from(["last", "name", "description", "draws", "key", "worlds", "count"]))
    s = {"name": draw(st.sampled_from(["fuzz", "x" * 100, "a.b", "A-1+2_", "0"])),
         "description": draw(st.sampled_from(["a hostile suite", "", None, "ünï", "x" * 1_000_000,
                                              Raw('&a "text"')])),
         "draws": draw(st.sampled_from([1, 1000, 2])),
         "worlds": [_any_world_entry(draw, box) for _ in range(draw(st.integers(1, 3)))]}
    for key in ("name", "description", "draws"):
        if draw(st.integers(0, 4)) == 0:
            del s[key]    # optional: the file's stem names the suite, default draws
    if bad == "last":
        s["worlds"].append(_bad_world_entry(draw, box))
    elif bad == "name":
        s["name"] = draw(st.sampled_from([n for n in _names(box) if not re.fullmatch(
            r"[A-Za-z0-9_+\-][A-Za-z0-9_.+\-]{0,99}", n)] + [None, 5, _alias_bomb(9, 9)]))
    elif bad == "description":
        s["description"] = draw(st.sampled_from([5, [1], {"a": 1}, True, 1.5, _alias_bomb(9, 9),
                                                 _deep(100_000, False)]))
    elif bad == "draws":
        s["draws"] = draw(st.sampled_from([1001, 1_000_000, 0, -1, "3", 1.5, Raw("1e3"), True, None,
                                           2**64, _alias_bomb(9, 9), Raw("9" * 5000)]))
    elif bad == "key":
        s[draw(st.sampled_from(["draw", "world", "Worlds", "", "../x"]))] = 1
    elif bad == "worlds":
        s["worlds"] = draw(st.sampled_from(["rectangle_s", {}, [], None, 5, _deep(100_000, False),
                                            _alias_bomb(9, 9)]))
    else:
        s["worlds"] = [draw(st.sampled_from(SHIPPED))] * draw(st.sampled_from([1001, 5000]))
    text = _yaml(s)
    return text, f"invalid {bad}: {text[:300]!r}"


@_fuzz(120)
@given(data=st.data())
def test_suite_yaml(tmp_path, data):
    box, out = _sandbox(tmp_path)
    world, wlabel = hostile_world(data.draw, box)
    (box / "in" / "w.yaml").write_bytes(world)
    os.mkfifo(box / "in" / "fifo.yaml")
    text, label = hostile_suite(data.draw, box)
    f = box / "in" / data.draw(st.sampled_from(["s.yaml", "s.yml", "ünï.yaml", ".s.yaml"]))
    f.write_text(text)
    _check(bench_main, ["run", "--suite", str(f), "--algo", "oracle", "--repeats", "1", "--out",
                        str(out), "--no-progress", "--no-figures", "--jobs", "1"],
           tmp_path, box, (out,), (str(f),),
           f"suite YAML {f.name}: {label} (w.yaml: {wlabel})", guards=_no_run)


# --- run folders: results.json and run.json -----------------------------------------------

@pytest.fixture(scope="module")
def base_run(tmp_path_factory, log_cache):
    """Two shards of one oracle run on the tiny world, and its true map as a map_server pair
    (for `bench add --map`); run in this process, so the children find numba compiled."""
    d = tmp_path_factory.mktemp("base")
    for k in (1, 2):
        assert bench_main(["run", "--world", str(TINY), "--algo", "oracle", "--repeats", "2",
                           "--shard", f"{k}/2", "--jobs", "1", "--no-progress", "--no-figures",
                           "--out", str(d / f"s{k}")]) == 0
    assert worlds_main(["render", str(TINY), "--out", str(d / "gt")]) == 0
    assert bench_main(["report", str(d / "s1")]) == 0     # the figures' imports, before forking
    return d


BAD_ROW_VALUES = {
    "world": [5, None, "../x", "/abs/x", "a/b", "..", "", "ünï", "x" * 101, ".x", []],
    "algo": [5, None, "../x", "a/b", "..", "", "名前"],
    "repeat": ["x", 1.5, -1, 2**63, True, None, "0", [], 10**30],
    "draw": [-1, "x", 1.5, True],
    "log_seed": [2**63, -2**63 - 1, "x", 1.5, True],
    "map_file": ["../X", "/abs/x", "maps/../../x", "", "a//b", "maps/tiny/oracle/../../../../x", 5,
                 []],
    "status": ["OK", None, 5, ""],
    "precision": ["x", True, [], {}],
    "error": [5, [], {}],
}
FREE_VALUES = [math.nan, math.inf, -math.inf, 1e308, -1e308, None, "x" * 100_000, "ünï\u2028",
               "\ud800", [], {}, 0, -1, 2**62, True]
SPEC_VALUES = {
    "worlds": [5, "x", [], ["../x"], [None], ["/dev/zero"], ["rectangle_s"], ["no_such"], [[1]],
               {"a": 1}, "W_FILE"],
    "algos": [[], ["../x"], [5], "oracle", ["nope"], ["oracle", "oracle"], None],
    "repeats": [0, -1, "x", 1.5, True, 10**15, 2**63, None, 100_000],
    "noise": [5, "../x", "", "/dev/zero", "nope", None, "x.yaml"],
    "seed": [-1, 2**70, "x", 1.5, None, True],
    "vary": ["x", 5, None, "data"],
    "configs": [{"oracle": "../../etc/passwd"}, {"oracle": 5}, "x", [], {"../x": "y"},
                {"oracle": "/dev/zero"}],
    "draws": [0, 10**9, "x", 2],
    "min_coverage": [-1, 2, "x", None],
    "suite": [5, "../x", None],
    "logs": [["/dev/zero"], "x", [5], ["BOX"]],
    "overrides": ["x", {"oracle": {"x": 1}}, {"oracle": "x"}, []],
    "shard": [[0, 1], [1], "1/2", [2, 1], [1, 2**63], [True, 1], None, [1.0, 2.0]],
}


def _json_text(data, raws: dict[str, str]) -> str:
    """json.dumps(data) with every string equal to a key of `raws` replaced by its raw text."""
    text = json.dumps(data)
    for k, v in raws.items():
        text = text.replace(json.dumps(k), v)
    return text


def _rows_of(data):
    rows = data.get("rows") if isinstance(data, dict) else None
    return rows if isinstance(rows, list) and rows else None


def mutate_results(draw, data: dict, must_break: bool) -> tuple[bytes, str]:
    """results.json bytes and a label: hostile changes, at least one that makes the file
    invalid when must_break (resume must never start a run)."""
    data = copy.deepcopy(data)
    raws: dict[str, str] = {}
    labels = []
    bad_kinds = ["binary", "truncated", "deep", "not_mapping", "bad_field", "rows_type",
                 "top_type", "duplicate", "huge_int", "format"]
    free_kinds = ["free_field", "many_rows", "no_rows", "nested_ok", "extra_top"]
    kinds = draw(st.lists(st.sampled_from(free_kinds + bad_kinds), min_size=1, max_size=3))
    if must_break and not set(kinds) & set(bad_kinds):
        kinds.append(draw(st.sampled_from(bad_kinds)))
    # the free changes first: a later one (no rows) must not undo a breaking one
    kinds.sort(key=lambda k: k in bad_kinds)
    tail, broke = None, False
    for kind in kinds:
        rows = _rows_of(data)
        # whether this breaking change finds what it needs (an earlier one may have removed it)
        applies = (kind in ("binary", "truncated", "deep", "top_type", "huge_int")
                   or (kind in ("rows_type", "format") and isinstance(data, dict))
                   or (kind in ("not_mapping", "duplicate") and rows is not None)
                   or (kind == "bad_field" and rows is not None and isinstance(rows[0], dict)))
        broke |= kind in bad_kinds and applies
        if kind in ("binary", "truncated"):
            tail = kind
        elif kind == "deep":
            raws["@@DEEP@@"] = "[" * (n := draw(st.sampled_from([101, 1000, 100_000]))) + "]" * n
            spot = draw(st.sampled_from(["top", "rows", "field"]))
            if spot == "top" or rows is None or (spot == "field" and not isinstance(rows[0], dict)):
                data = "@@DEEP@@"
            elif spot == "rows":
                data["rows"] = "@@DEEP@@"
            else:
                rows[0]["slam_stats"] = "@@DEEP@@"
        elif kind == "not_mapping" and rows:
            rows[draw(st.integers(0, len(rows) - 1))] = draw(st.sampled_from([5, "x", [], None, True]))
        elif kind == "bad_field" and rows and isinstance(rows[0], dict):
            key = draw(st.sampled_from(sorted(BAD_ROW_VALUES)))
            rows[0][key] = draw(st.sampled_from(BAD_ROW_VALUES[key]))
            kind = f"{key} = {str(rows[0][key])[:30]!r}"
        elif kind == "rows_type" and isinstance(data, dict):
            data["rows"] = draw(st.sampled_from([{}, "x", None, 5]))
        elif kind == "top_type":
            data = draw(st.sampled_from([[], "x", 5, None, [data]]))
        elif kind == "duplicate" and rows:
            rows.append(copy.deepcopy(rows[0]))
        elif kind == "huge_int":
            raws["@@INT@@"] = "9" * 5000
            if rows and isinstance(rows[0], dict):
                rows[0][draw(st.sampled_from(["repeat", "precision", "extra"]))] = "@@INT@@"
            else:
                data = {"format": "@@INT@@", "rows": []}
        elif kind == "format" and isinstance(data, dict):
            data["format"] = draw(st.sampled_from([2, "1", None, [], 0]))
        elif kind == "free_field" and rows and isinstance(rows[0], dict):
            key = draw(st.sampled_from(["precision", "ate_m", "note", "slam_stats", "versions",
                                        "new_field", "wall_time_s", "noise", "surface_tau_m"]))
            rows[0][key] = draw(st.sampled_from(FREE_VALUES))
        elif kind == "many_rows" and rows and isinstance(rows[0], dict) \
                and _is_number(rows[0].get("repeat")):
            n = draw(st.sampled_from([100, 100, 2000, 20_000]))
            rows[:] = [dict(rows[0], repeat=rows[0]["repeat"] + 2 * i) for i in range(n)]
            kind = f"{n} rows"
        elif kind == "no_rows" and isinstance(data, dict):
            data["rows"] = []
        elif kind == "nested_ok" and rows and isinstance(rows[0], dict):
            raws["@@NEST@@"] = "[" * 90 + "]" * 90
            rows[0]["slam_stats"] = "@@NEST@@"
        elif kind == "extra_top" and isinstance(data, dict):
            data[draw(st.sampled_from(["extra", "", "rows2"]))] = draw(JSONISH)
        labels.append(kind)
    if must_break and not broke:
        tail = "truncated"
        labels.append("truncated")
    text = _json_text(data, raws)
    raw = text.encode()
    if tail == "truncated" and len(raw) > 1:
        raw = raw[:draw(st.integers(1, len(raw) - 1))]
    elif tail == "binary":
        form = draw(st.sampled_from(["random", "utf-16", "ff", "nul"]))
        if form == "random":
            raw = b"\xff" + draw(st.binary(max_size=200))
        elif form == "utf-16":
            raw = text.encode("utf-16")
        elif form == "ff":
            k = draw(st.integers(0, len(raw) - 1))
            raw = raw[:k] + b"\xff" + raw[k + 1:]
        else:
            raw = b"\0" * 1000
        labels.append(form)
    return raw, ", ".join(labels)


def mutate_run(draw, data: dict, box: Path) -> tuple[bytes, str]:
    """run.json bytes and a label: hostile spec fields, world table or file shape."""
    data = copy.deepcopy(data)
    kind = draw(st.sampled_from(["spec", "spec", "spec", "worlds", "no_spec", "top", "binary",
                                 "deep"]))
    if kind == "spec":
        key = draw(st.sampled_from(sorted(SPEC_VALUES)))
        value = copy.deepcopy(draw(st.sampled_from(SPEC_VALUES[key])))
        if value == "W_FILE":
            value = [str(box / "in" / "w.yaml")]
        if value == ["BOX"]:
            value = [str(box)]
        data["spec"][key] = value
        return json.dumps(data).encode(), f"spec.{key} = {str(value)[:40]}"
    if kind == "worlds":
        data["worlds"] = draw(st.sampled_from([{"../x": {}}, {"tiny": 5}, "x", [], {"": {}},
                                               {"tiny": {"name": "../x", "file": "/dev/zero"}}]))
        return json.dumps(data).encode(), f"worlds = {str(data['worlds'])[:40]}"
    if kind == "no_spec":
        del data["spec"]
    elif kind == "top":
        data = draw(st.sampled_from([[], "x", None, 5]))
    elif kind == "binary":
        return b"\xff\xfe" + draw(st.binary(max_size=100)), kind
    else:
        n = draw(st.sampled_from([101, 100_000]))
        return ('{"spec": ' + "[" * n + "]" * n + "}").encode(), f"deep {n}"
    return json.dumps(data).encode(), kind


def _copy_run(base: Path, name: str, box: Path) -> Path:
    d = box / "in" / name
    shutil.copytree(base / name, d)
    return d


def _run_command(base_run: Path, box: Path, out: Path, command: str, figures: bool, mutate) -> None:
    """Copy the base run's shards into the box, let mutate(shard folders) damage them, run
    `command` (report | merge | resume | add) on them and check it."""
    s1 = _copy_run(base_run, "s1", box)
    s2 = _copy_run(base_run, "s2", box) if command == "merge" else None
    label = mutate([s1] if s2 is None else [s1, s2])
    fig = [] if figures else ["--no-figures"]
    guards = None
    if command == "report":
        argv, outs = ["report", str(s1), *fig], (s1,)
    elif command == "merge":
        argv, outs = ["merge", str(s1), str(s2), "--out", str(out), *fig], (out,)
    elif command == "resume":
        argv = ["run", "--resume", str(s1), "--jobs", "1", "--no-progress", "--no-figures"]
        outs = (s1,)
        guards = _no_run
    else:
        argv = ["add", str(s1), "--world", "tiny", "--algo", "outside",
                "--map", str(base_run / "gt" / "tiny.yaml"), *fig]
        outs = (s1,)
    _check(bench_main, argv, box.parent, box, outs, tuple(str(d) for d in (s1, s2, out) if d),
           label, guards=guards, run_dirs=outs)


@pytest.mark.parametrize("command", ["report", "merge", "resume", "add"])
@_fuzz(30)
@given(data=st.data())
def test_run_folder(base_run, tmp_path, command, data):
    box, out = _sandbox(tmp_path)
    world, _ = hostile_world(data.draw, box)
    (box / "in" / "w.yaml").write_bytes(world)

    def mutate(shards: list[Path]) -> str:
        labels = []
        for d in data.draw(st.sampled_from([shards[:1], shards[1:], shards])) or shards:
            what = data.draw(st.sampled_from(["results", "run", "both"]))
            if command == "resume" or what != "run":
                raw, label = mutate_results(data.draw, json.loads((d / "results.json").read_text()),
                                            must_break=command == "resume")
                (d / "results.json").write_bytes(raw)
                labels.append(f"{d.name}/results.json: {label}")
            if what != "results":
                raw, label = mutate_run(data.draw, json.loads((d / "run.json").read_text()), box)
                (d / "run.json").write_bytes(raw)
                labels.append(f"{d.name}/run.json: {label}")
        return "; ".join(labels)

    _run_command(base_run, box, out, command, figures=data.draw(st.integers(0, 4)) == 0,
                 mutate=mutate)


# --- the cases, each once -----------------------------------------------------------

def _world_with(**fields) -> dict:
    w = copy.deepcopy(BASE_WORLD)
    w.update(fields)
    return w


def _boxes(n: int) -> list:
    rng = np.random.default_rng(0)
    return [{"box": {"center": [round(float(x), 3), round(float(y), 3)], "size": [0.02, 0.02]}}
            for x, y in zip(rng.uniform(1.0, 2.0, n), rng.uniform(1.3, 1.8, n))]


KNOWN_WORLDS = {
    "name ../x": _world_with(name="../x"), "name a/b": _world_with(name="a/b"),
    "name ..": _world_with(name=".."), "name empty": _world_with(name=""),
    "name unicode": _world_with(name="名前"), "name ../victim": _world_with(name="../victim"),
    "description alias bomb": _world_with(description=_alias_bomb(9, 9)),
    "resolution alias bomb": _world_with(resolution=_alias_bomb(9, 9)),
    "name alias bomb": _world_with(name=_alias_bomb(9, 9)),
    "circle of 10^8 sides": _world_with(obstacles=[{"circle": {"center": [1.0, 1.5], "radius": 0.2,
                                                               "sides": 100_000_000}}]),
    "20,000 obstacles": _world_with(obstacles=_boxes(20_000)),
    "wall at 1e308": _world_with(walls={"polylines": [[[0, 0], [1e308, 0], [3, 2], [0, 2], [0, 0]]]}),
    "start at 1e308": _world_with(robot={"start": [1e308, 0.6, 0.0]}),
    "obstacle at nan": _world_with(obstacles=[{"box": {"center": [math.nan, 1.0],
                                                       "size": [0.3, 0.3]}}]),
    "route at inf": _world_with(route=[[math.inf, 0.6]]),
    "100,000-deep nesting": _world_with(description=_deep(100_000, False)),
    "5000-digit integer": _world_with(resolution=Raw("9" * 5000)),
    "!!int 1.5": _world_with(resolution=Raw("!!int 1.5")),
    "!!float x": _world_with(resolution=Raw("!!float x")),
    "3.9 MB description": _world_with(description="x" * 3_900_000),
}
KNOWN_SUITES = {
    "name alias bomb": {"name": _alias_bomb(9, 9), "worlds": ["rectangle_s"]},
    "draws alias bomb": {"draws": _alias_bomb(9, 9), "worlds": ["rectangle_s"]},
    "draws 1,000,000": {"draws": 1_000_000, "worlds": ["rectangle_s"]},
    "generated 100000 x 100000": {"worlds": [{"generate": "office", "seed": 0,
                                              "size": [100_000, 100_000]}]},
    "name ../x": {"name": "../x", "worlds": ["rectangle_s"]},
    "world /dev/zero": {"worlds": ["rectangle_s", "/dev/zero"]},
}


def _row(key, value):
    def edit(data):
        data["rows"][0][key] = value
    return edit


def _spec(key, value):
    def edit(data):
        data["spec"][key] = value
    return edit


def _not_a_row(data):
    data["rows"][0] = 5


# results.json and run.json edits; a results.json edit also breaks the file for resume
KNOWN_RESULTS = {
    "binary": b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR\xff\xfe",
    "100,000-deep": b'{"format": 1, "rows": ' + b"[" * 100_000 + b"]" * 100_000 + b"}",
    "repeat 'x'": _row("repeat", "x"), "world 5": _row("world", 5), "row not a mapping": _not_a_row,
    "map_file ../X": _row("map_file", "../X"), "world ../x": _row("world", "../x"),
}
KNOWN_RUNS = {
    "spec.repeats 10^15": _spec("repeats", 10**15), "spec.draws 10^9": _spec("draws", 10**9),
    "spec.noise /dev/zero": _spec("noise", "/dev/zero"),
    "spec.worlds /dev/zero": _spec("worlds", ["/dev/zero"]),
    "spec.configs /dev/zero": _spec("configs", {"oracle": "/dev/zero"}),
    "spec.seed 2^70": _spec("seed", 2**70), "spec.algos '../x'": _spec("algos", ["../x"]),
}


@pytest.mark.parametrize("case", sorted(KNOWN_WORLDS))
def test_known_world(tmp_path, case):
    box, out = _sandbox(tmp_path)
    f = box / "in" / "w.yaml"
    f.write_text(_yaml(KNOWN_WORLDS[case]))
    _check(worlds_main, ["render", str(f), "--out", str(out)], tmp_path, box, (out,), (str(f),), case)


@pytest.mark.parametrize("case", sorted(KNOWN_SUITES))
def test_known_suite(tmp_path, case):
    box, out = _sandbox(tmp_path)
    f = box / "in" / "s.yaml"
    f.write_text(_yaml(KNOWN_SUITES[case]))
    _check(bench_main, ["run", "--suite", str(f), "--algo", "oracle", "--repeats", "1", "--out",
                        str(out), "--no-progress", "--no-figures", "--jobs", "1"],
           tmp_path, box, (out,), (str(f),), case, guards=_no_run)


@pytest.mark.parametrize("command", ["report", "merge", "resume", "add"])
@pytest.mark.parametrize("case", sorted(KNOWN_RESULTS) + sorted(KNOWN_RUNS))
def test_known_run_folder(base_run, tmp_path, case, command):
    box, out = _sandbox(tmp_path)

    def mutate(shards: list[Path]) -> str:
        d = shards[-1]
        edit = KNOWN_RESULTS.get(case) or KNOWN_RUNS[case]
        name = "results.json" if case in KNOWN_RESULTS else "run.json"
        if isinstance(edit, bytes):
            (d / name).write_bytes(edit)
        else:
            data = json.loads((d / name).read_text())
            edit(data)
            (d / name).write_text(json.dumps(data))
        if command == "resume" and name == "run.json":
            _not_a_row(data := json.loads((d / "results.json").read_text()))
            (d / "results.json").write_text(json.dumps(data))   # never a real run
        return f"{d.name}/{name}: {case}"

    _run_command(base_run, box, out, command, figures=False, mutate=mutate)
