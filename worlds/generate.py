"""Procedural worlds: office, warehouse, hall and loop layouts drawn from a seed.

Each kind is a recipe (worlds.layouts) that fills a Draft (wall centre lines of one
thickness, obstacles as YAML mappings, start pose, optionally a route); then:
 1. the route is worlds.route.plan_route (office, warehouse, hall), or for a loop the
    ring's centre line with cut corners, ending where it started;
 2. the YAML text is reloaded by worlds.load (start clear of walls, waypoints reachable)
    and the route must see at least MIN_COVERAGE of the true wall cells within
    COVERAGE_RANGE m (every wall seen from near, where the lidar's noise is smallest). A
    draw that fails is replaced by the next one, drawn from
    np.random.default_rng((seed, attempt)), up to MAX_DRAWS draws.
Round pillars are 20-gons, as ray casting (route planning, the coverage check, the
simulated lidar) costs time in proportion to the segment count. Coordinates are rounded to
mm, not to the 0.05 m grid: most wall faces fall anywhere in a cell, and one outer wall
per axis-aligned kind has its inner face exactly on a cell edge (x = 0), the two cases a
rasterizer and a ray caster must both get right.
"""
from __future__ import annotations

import math
import re

import numpy as np
import yaml

from worlds.coverage import wall_coverage
from worlds.layouts import RECIPES, Draft, Rejected, mm, xy
from worlds.load import world_from_dict
from worlds.route import plan_route
from worlds.yamlio import InputError, _suggest, short

__all__ = ["KINDS", "DEFAULT_SIZE", "MIN_SIZE", "MAX_AREA", "check_args", "generate_world",
           "generate_yaml", "parse_size"]

KINDS = ("office", "warehouse", "hall", "loop")
DEFAULT_SIZE = {"office": (10.0, 8.0), "warehouse": (12.0, 9.0), "hall": (9.0, 7.0), "loop": (12.0, 8.0)}
# smallest W x H (m, outer wall centre lines) for which every recipe step still fits
MIN_SIZE = {"office": (5.0, 4.0), "warehouse": (5.5, 4.5), "hall": (4.0, 3.0), "loop": (4.5, 4.0)}
# largest area (m², outer wall centre lines): drawing and checking the route take time and
# memory growing with the area (a 20 x 16 m office: 3.5 min, 0.5 GB; 31 x 32 m: 19 min, 1.3 GB)
MAX_AREA = 400.0

RESOLUTION = 0.05
# the route passes within this of every wall, so each wall gets hits from near (the LDS-01's
# noise grows with range: +-5 % beyond 0.5 m); the generated files depend on these values
PLAN_RANGE = 1.8        # range (m) the planned route is made for
COVERAGE_RANGE = 1.8    # range (m) of the coverage check
MIN_COVERAGE = 0.97     # margin over the 0.95 the simulator requires of a route
MAX_DRAWS = 6


# --- checks, data and YAML ---------------------------------------------------------------

def check_args(kind, seed, size) -> tuple[float, float]:
    """The (W, H) to draw, in mm; InputError naming the field for a bad kind, seed or size."""
    if kind not in KINDS:
        hint = _suggest(str(kind), list(KINDS))
        raise InputError(f"kind: unknown kind {kind!r}, expected one of {', '.join(KINDS)}"
                         + (hint if "did you mean" in hint else ""))
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed: expected a non-negative integer, got {short(seed)}")
    if size is None:
        return DEFAULT_SIZE[kind]
    try:
        W, H = (float(v) for v in size)
    except (TypeError, ValueError):
        raise InputError(f"size: expected (W, H) in metres, got {short(size)}") from None
    if not (math.isfinite(W) and math.isfinite(H) and W > 0 and H > 0):
        raise InputError(f"size: must be positive, got {W:g} x {H:g}")
    W, H = mm(W), mm(H)
    mw, mh = MIN_SIZE[kind]
    if W < mw or H < mh:
        raise InputError(f"size: {W:g} x {H:g} m is too small for kind {kind} (minimum {mw:g} x {mh:g} m)")
    if W * H > MAX_AREA:
        raise InputError(f"size: {W:g} x {H:g} m is {W * H:,.0f} m², more than the {MAX_AREA:g} m² "
                         "a generated world may have")
    return W, H


def _data(kind: str, seed: int, size: tuple[float, float], draft: Draft) -> dict:
    """Plain YAML data of a draft, keys in the order of the World YAML contract."""
    default = size == DEFAULT_SIZE[kind]
    name = f"{kind}_s{seed}" if default else f"{kind}_s{seed}_{size[0]:g}x{size[1]:g}"
    return {"name": name, "description": f"{draft.about}; generated, seed {seed}", "resolution": RESOLUTION,
            "walls": {"thickness": draft.thickness, "polylines": draft.polylines},
            "obstacles": draft.obstacles, "robot": {"start": draft.start}, "route": draft.route}


def _checked(data: dict) -> dict:
    """data with its route planned if it has none, once the YAML text loads and the route
    sees MIN_COVERAGE of the walls at COVERAGE_RANGE m; raises Rejected or InputError."""
    where = f"{data['name']} (generated)"
    if data["route"] is None:
        world = world_from_dict({**data, "route": None}, where=where)
        data["route"] = [xy(p) for p in plan_route(world, max_range=PLAN_RANGE)]
    world = world_from_dict(yaml.safe_load(_dump(data)), where=where)
    cov = wall_coverage(world, np.vstack([world.start[:2], world.route]), max_range=COVERAGE_RANGE)
    if cov < MIN_COVERAGE:
        raise Rejected(f"the route sees {cov:.3f} of the walls at {COVERAGE_RANGE:g} m, "
                        f"under {MIN_COVERAGE}")
    return data


def generate_world(kind: str, seed: int, size: tuple[float, float] | None = None) -> dict:
    """Plain World YAML data (docs/worlds.md) of a `kind` world drawn from `seed`.

    kind: one of KINDS; seed: int >= 0; size: (W, H) m of the outer walls' centre lines,
    default DEFAULT_SIZE[kind], at least MIN_SIZE[kind]. Coordinates in m, rounded to mm.
    Same arguments, same data. Raises InputError for a bad argument, or when MAX_DRAWS
    draws in a row fail the checks (module docstring).
    """
    W, H = check_args(kind, seed, size)
    why = ""
    for attempt in range(MAX_DRAWS):
        rng = np.random.default_rng(seed if attempt == 0 else (int(seed), attempt))
        try:
            return _checked(_data(kind, int(seed), (W, H), RECIPES[kind](rng, W, H)))
        except (Rejected, InputError) as err:
            why = str(err)
    raise InputError(f"{kind} seed {seed}: none of {MAX_DRAWS} draws passed the checks (last: {why})")


def generate_yaml(kind: str, seed: int, size: tuple[float, float] | None = None) -> str:
    """The YAML text of generate_world(kind, seed, size): points in flow style, one route
    waypoint per line; same arguments, same bytes."""
    return _dump(generate_world(kind, seed, size))


class _Flow(list):
    """A list written in YAML flow style: [x, y]."""


class _FlowMap(dict):
    """A mapping written in YAML flow style: {box: {center: [x, y], ...}}."""


class _Dumper(yaml.SafeDumper):
    """yaml.SafeDumper that writes _Flow and _FlowMap in flow style."""


_Dumper.add_representer(_Flow, lambda d, v: d.represent_sequence("tag:yaml.org,2002:seq", v, True))
_Dumper.add_representer(_FlowMap, lambda d, v: d.represent_mapping("tag:yaml.org,2002:map", v, True))


def _dump(data: dict) -> str:
    """YAML text of world data: each polyline, obstacle and waypoint and the start in flow
    style on a line of its own (wrapped at 120 characters), the rest in block style."""
    styled = {**data,
              "walls": {"thickness": data["walls"]["thickness"],
                        "polylines": [_Flow(line) for line in data["walls"]["polylines"]]},
              "obstacles": [_FlowMap(o) for o in data["obstacles"]],
              "robot": {"start": _Flow(data["robot"]["start"])},
              "route": [_Flow(p) for p in data["route"]] if data["route"] is not None else None}
    return yaml.dump(styled, Dumper=_Dumper, sort_keys=False, width=120)


_SIZE_TEXT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+))\s*[xX]\s*([-+]?(?:\d+\.?\d*|\.\d+))\s*$")


def parse_size(text: str) -> tuple[float, float]:
    """'10x8' or '10.5x7.25' -> (W, H) in metres; InputError naming --size otherwise."""
    m = _SIZE_TEXT.match(text)
    if not m:
        raise InputError(f"--size: expected WxH in metres (e.g. 10x8), got {short(text)}")
    return float(m[1]), float(m[2])
