"""The four layouts of worlds.generate: office, warehouse, hall and loop, each a recipe of
named steps that fills a Draft (wall centre lines of one thickness, obstacles as YAML
mappings, start pose, optionally a route) from a random generator.

Obstacles are placed by rejection sampling, each at least GAP (0.55 m) from walls, doors,
the start and every other obstacle, so every passage is wider than 0.5 m and the robot's
free space stays connected. Coordinates are rounded to mm, not to the 0.05 m grid: most
wall faces fall anywhere in a cell, and one outer wall per axis-aligned kind has its inner
face exactly on a cell edge (x = 0).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from shapely.geometry import Point, Polygon, box
from shapely.ops import polylabel

from worlds.model import make_obstacle

__all__ = ["Draft", "Rejected", "RECIPES", "GAP", "mm", "xy"]

GAP = 0.55              # obstacles keep this far (m) from walls, doors, the start and each other
PILLAR_SIDES = 20       # pillars are 20-gons: ray casting cost grows with the segment count
_CUT = 0.35             # loop route: corners cut by a chord this far (m) along both legs


class Rejected(Exception):
    """A draw that fails the checks; the next draw replaces it."""


# --- plain values ------------------------------------------------------------------------

def mm(v: float) -> float:
    """v rounded to mm as a plain float (+ 0.0 turns -0.0 into 0.0)."""
    return round(float(v), 3) + 0.0


def _count(n: int, word: str) -> str:
    return f"{n} {word}{'s' * (n != 1)}"


def xy(p) -> list[float]:
    return [mm(p[0]), mm(p[1])]


def _thickness(rng: np.random.Generator) -> float:
    # even mm, so that half a thickness is whole mm and a face can sit exactly on a cell edge
    return mm(0.100 + 0.002 * rng.integers(0, 26))


def _box(centre, size, yaw: float = 0.0) -> dict:
    return {"box": {"center": xy(centre), "size": xy(size), "yaw": mm(yaw)}}


def _pillar(centre, radius: float) -> dict:
    """A round pillar drawn as a regular PILLAR_SIDES-gon (a plain YAML circle is a 128-gon)."""
    return {"circle": {"center": xy(centre), "radius": mm(radius), "sides": PILLAR_SIDES}}


def _shape(item: dict):
    """Shapely polygon of an obstacle mapping, as the loader builds it."""
    kind, params = next(iter(item.items()))
    if kind == "polygon":
        params = {"points": params}
    return make_obstacle(kind, params).polygon


# --- the draft ---------------------------------------------------------------------------

@dataclass
class Draft:
    """A world being drawn: wall centre lines (m), obstacles (YAML mappings), start, route."""

    thickness: float
    about: str = ""
    polylines: list = field(default_factory=list)
    obstacles: list = field(default_factory=list)
    start: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    route: list | None = None

    def wall(self, points) -> None:
        self.polylines.append([xy(p) for p in points])

    def place(self, rng: np.random.Generator, region, draw: Callable, count: int,
              keep_out=(), tries: int = 40) -> int:
        """Add up to `count` obstacles draw(rng, centre) -> mapping, centres uniform over
        region's bounds; each lies inside `region` (shapely, already GAP from the walls) and
        GAP m from the obstacles so far and from `keep_out`. Returns how many were placed."""
        if region.is_empty:
            return 0
        others = [_shape(o) for o in self.obstacles] + list(keep_out)
        x0, y0, x1, y1 = region.bounds
        placed = 0
        for _ in range(count * tries):
            if placed == count:
                break
            item = draw(rng, (rng.uniform(x0, x1), rng.uniform(y0, y1)))
            poly = _shape(item)
            if region.contains(poly) and all(poly.distance(g) >= GAP for g in others):
                self.obstacles.append(item)
                others.append(poly)
                placed += 1
        return placed


def _rect(x0: float, x1: float, y0: float, y1: float) -> Polygon:
    """Axis-aligned rectangle between two x and two y values in any order."""
    return box(min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1))


def _frame(rng: np.random.Generator, d: Draft, W: float, H: float) -> tuple[float, float, float, float]:
    """Outer rectangle of centre lines [x0, x0+W] x [y0, y0+H]: the left wall's inner face on
    x = 0 (a cell edge), the bottom one at a random mm. Returns the inner faces xl, yb, xr, yt."""
    t = d.thickness
    x0, y0 = -t / 2, mm(rng.uniform(-0.05, 0.0))
    d.wall([(x0, y0), (x0 + W, y0), (x0 + W, y0 + H), (x0, y0 + H), (x0, y0)])
    return x0 + t / 2, y0 + t / 2, x0 + W - t / 2, y0 + H - t / 2


def _split(rng: np.random.Generator, length: float, minimum: float, wall: float, most: float) -> list[float]:
    """Widths of n parts >= minimum that fill `length` with a wall between neighbours,
    n drawn so the parts average at most `most` m."""
    n_max = max(1, int((length + wall) // (minimum + wall)))
    n_min = min(n_max, max(1, math.ceil((length + wall) / (most + wall))))
    n = int(rng.integers(n_min, n_max + 1))
    slack = length - (n - 1) * wall - n * minimum
    return list(minimum + slack * rng.dirichlet(np.full(n, 2.0)))


# --- office ------------------------------------------------------------------------------

_ROOM_DEPTH = 2.2   # m, face to face


def _office(rng: np.random.Generator, W: float, H: float) -> Draft:
    """Outer rectangle, a corridor along x, rooms off it (both sides when tall enough) with
    one door each, furniture boxes and pillars in the rooms; start in the corridor."""
    d = Draft(_thickness(rng))
    t = d.thickness
    xl, yb, xr, yt = _frame(rng, d, W, H)
    cw = rng.uniform(1.2, 1.6)
    if yt - yb >= cw + 2 * t + 2 * _ROOM_DEPTH:
        below = rng.uniform(_ROOM_DEPTH, yt - yb - cw - 2 * t - _ROOM_DEPTH)
        c0 = yb + below + t                                   # corridor's lower face
        n = _rooms(rng, d, xl, xr, c0 - t / 2, yb - t / 2, c0 - t, yb)
    else:
        c0, n = yb, 0
    n += _rooms(rng, d, xl, xr, c0 + cw + t / 2, yt + t / 2, c0 + cw + t, yt)
    d.start = [mm(xl + rng.uniform(0.5, 1.0)), mm(c0 + cw / 2), 0.0]
    d.about = f"office {W:g} m x {H:g} m: {_count(n, 'room')} off a {cw:.2f} m corridor"
    return d


def _rooms(rng, d: Draft, xl: float, xr: float, y_door: float, y_end: float,
           face_door: float, face_end: float) -> int:
    """Rooms along x between the corridor wall (centre line y_door) and the outer wall
    (centre line y_end); face_*: the rooms' faces on those walls. Returns the room count."""
    t = d.thickness
    widths = _split(rng, xr - xl, 2.0, t, 3.5)
    x, doors = xl, []
    for i, w in enumerate(widths):
        if i:
            d.wall([(x - t / 2, y_door), (x - t / 2, y_end)])  # partition
        dw = rng.uniform(0.8, 1.0)
        e = rng.uniform(x + 0.15, x + w - 0.15 - dw)
        doors.append((e, e + dw))
        inward = math.copysign(1.0, face_end - face_door)
        _furnish(rng, d, _rect(x, x + w, face_door, face_end).buffer(-GAP, join_style="mitre"),
                 _rect(e, e + dw, face_door, face_door + inward))   # keep the way in clear
        x += w + t
    # the corridor wall in pieces between the doors; square caps reach t/2 past each end
    ends = [xl - t / 2] + [v for e0, e1 in doors for v in (e0 - t / 2, e1 + t / 2)] + [xr + t / 2]
    for a, b in zip(ends[::2], ends[1::2]):
        d.wall([(a, y_door), (b, y_door)])
    return len(widths)


def _furnish(rng, d: Draft, region, door) -> None:
    """Desks and cupboards (a few turned slightly) and maybe a pillar in one room."""
    def furniture(rng, c):
        yaw = rng.choice([0.0, np.pi / 2]) + (rng.normal(0.0, 0.12) if rng.random() < 0.4 else 0.0)
        return _box(c, (rng.uniform(0.5, 1.6), rng.uniform(0.4, 0.8)), yaw)

    def pillar(rng, c):
        return _pillar(c, rng.uniform(0.1, 0.25))

    d.place(rng, region, furniture, int(rng.integers(1, 3)) + (region.area > 3.0), keep_out=[door])
    if rng.random() < 0.6:
        d.place(rng, region, pillar, 1, keep_out=[door])


# --- warehouse ---------------------------------------------------------------------------

def _warehouse(rng: np.random.Generator, W: float, H: float) -> Draft:
    """A hall with shelf rows along x, aisles >= 1.2 m between them, cross aisles at both
    ends (and maybe one in the middle); half the time a loading dock with pallets on top."""
    d = Draft(_thickness(rng))
    xl, yb, xr, yt = _frame(rng, d, W, H)
    spans = _shelf_spans(rng, xl, xr)
    depth = rng.uniform(0.5, 1.0)                  # double-sided racking
    rows = int((yt - yb - 1.2) // (depth + 1.2))   # as many as 1.2 m aisles allow
    dock = rows >= 3 and rng.random() < 0.5
    rows -= dock
    slack = yt - yb - rows * depth - (rows + 1) * 1.2
    if dock:   # the top aisle takes most of the slack: room for pallets beyond a 1.2 m aisle
        aisles = 1.2 + slack * np.r_[0.15 * rng.dirichlet(np.full(rows, 4.0)), 0.85]
    else:
        aisles = 1.2 + slack * rng.dirichlet(np.full(rows + 1, 4.0))
    y = yb
    for aisle in aisles[:-1]:
        y += aisle
        for a, b in spans:
            d.obstacles.append(_box(((a + b) / 2, y + depth / 2), (b - a, depth)))
        y += depth

    def pallet(rng, c):
        return _box(c, rng.uniform(0.8, 1.2, 2), rng.normal(0.0, 0.1) if rng.random() < 0.3 else 0.0)

    n = 0
    if dock:
        n = d.place(rng, box(xl + GAP, y + 1.2, xr - GAP, yt - GAP), pallet, int(rng.integers(2, 6)))
    d.start = [mm((xl + spans[0][0]) / 2), mm(yb + aisles[0] / 2), 0.0]
    dock_text = f", a loading dock with {_count(n, 'pallet')}" if dock else ""
    d.about = (f"warehouse {W:g} m x {H:g} m: {_count(rows, 'shelf row')} {depth:.2f} m deep, "
               f"{len(spans) + 1} cross aisles{dock_text}")
    return d


def _shelf_spans(rng: np.random.Generator, xl: float, xr: float) -> list[tuple[float, float]]:
    """x extents of the shelf runs in a row: cross aisles 1.3-2.0 m at both ends, and a
    1.2-1.6 m one in the middle of long rows half the time."""
    a, b = xl + rng.uniform(1.3, 2.0), xr - rng.uniform(1.3, 2.0)
    if b - a >= 7.0 and rng.random() < 0.5:
        mid, gap = rng.uniform(a + 3.0, b - 3.0), rng.uniform(1.2, 1.6)
        return [(a, mid - gap / 2), (mid + gap / 2, b)]
    return [(a, b)]


# --- hall --------------------------------------------------------------------------------

def _hall(rng: np.random.Generator, W: float, H: float) -> Draft:
    """One slanted outline around a centre (convex or concave), pillars and boxes at any yaw;
    start where the hall is widest."""
    d = Draft(_thickness(rng))
    outline = _outline(rng, W, H)
    d.wall(outline)
    inner = Polygon(d.polylines[0]).buffer(-d.thickness / 2, join_style="mitre")
    centre = polylabel(inner, tolerance=0.01)
    d.start = [mm(centre.x), mm(centre.y), mm(rng.uniform(-3.0, 3.0))]

    def item(rng, c):
        if rng.random() < 0.5:
            return _pillar(c, rng.uniform(0.15, 0.35))
        return _box(c, (rng.uniform(0.4, 1.4), rng.uniform(0.3, 0.9)), rng.uniform(-np.pi / 2, np.pi / 2))

    count = int(np.clip(inner.area / 6.0, 2, 10))
    n = d.place(rng, inner.buffer(-GAP), item, count, keep_out=[Point(d.start[:2]).buffer(0.3)])
    shape = "convex" if Polygon(d.polylines[0]).equals(Polygon(d.polylines[0]).convex_hull) else "concave"
    d.about = (f"hall {W:g} m x {H:g} m: {shape}, {len(outline) - 1} slanted walls, "
               f"{_count(n, 'obstacle')} (pillars, boxes)")
    return d


def _outline(rng: np.random.Generator, W: float, H: float) -> np.ndarray:
    """(N+1, 2) closed centre line: N = 5-9 vertices at jittered angles around a centre, on
    a circle (convex) or with one or two pulled in (concave), scaled to fill W x H; redrawn
    until every side is >= 1 m, every corner turns by at most 125 degrees (no slivers) and
    it fills at least half its box (no thin halls)."""
    x0, y0 = mm(rng.uniform(0.0, 0.05)), mm(rng.uniform(0.0, 0.05))
    concave = rng.random() < 0.6
    for _ in range(200):
        n = int(rng.integers(5, 10))
        ang = 2 * np.pi * (np.arange(n) + rng.uniform(-0.3, 0.3, n)) / n + rng.uniform(0, 2 * np.pi)
        rad = np.ones(n)
        if concave:   # one or two vertices pulled in towards the centre
            rad = rng.uniform(0.8, 1.0, n)
            rad[rng.choice(n, size=int(rng.integers(1, 3)), replace=False)] = rng.uniform(0.3, 0.6)
        p = rad[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        p = (p - p.min(axis=0)) / np.ptp(p, axis=0) * [W, H] + [x0, y0]
        p = np.array([xy(q) for q in p])
        side = np.roll(p, -1, axis=0) - p
        prev = np.roll(side, 1, axis=0)
        turn = np.arctan2(prev[:, 0] * side[:, 1] - prev[:, 1] * side[:, 0], np.sum(prev * side, axis=1))
        if (np.hypot(*side.T).min() >= 1.0 and np.abs(turn).max() <= np.radians(125)
                and Polygon(p).area >= 0.5 * W * H):
            return np.vstack([p, p[:1]])
    raise Rejected("no hall outline with sides >= 1 m, corners turning <= 125 degrees "
                    "and half the area of its box")


# --- loop --------------------------------------------------------------------------------

def _loop(rng: np.random.Generator, W: float, H: float) -> Draft:
    """Ring corridors 1.0-1.5 m wide around one block or two (a figure eight), walls with
    small jogs; the route drives the ring(s) on the corridor centre lines and ends at the start."""
    d = Draft(_thickness(rng))
    t = d.thickness
    x0, y0 = -t / 2, mm(rng.uniform(-0.05, 0.0))
    xl, yb, xr, yt = x0 + t / 2, y0 + t / 2, x0 + W - t / 2, y0 + H - t / 2
    wl, wr, wb, wt, wm = (mm(w) for w in rng.uniform(1.0, 1.5, 5))
    by = (yb + wb, yt - wt)                                   # blocks' faces in y
    blocks = [(xl + wl, xr - wr)]
    if xr - wr - xl - wl >= 2.2 + wm and rng.random() < 0.5:
        m = mm(rng.uniform(xl + wl + 1.1, xr - wr - 1.1 - wm))
        blocks = [(xl + wl, m), (m + wm, xr - wr)]
    # outer protrusions stay beside a block (straight corridor) and leave >= 0.35 m to the centre line
    beside = [(blocks[0][0] + 0.3, blocks[-1][1] - 0.3)] if len(blocks) == 1 else \
        [(a + 0.3, b - 0.3) for a, b in blocks]
    spans = [beside[rng.integers(len(beside))], (by[0] + 0.3, by[1] - 0.3)]
    jogs = [_jog(rng, side, spans[side % 2], min(0.3, w / 2 - 0.35))
            for side, w in enumerate((wb, wr, wt, wl)) if rng.random() < 0.4]
    d.wall(_ring(x0, y0, x0 + W, y0 + H, [j for j in jogs if j]))
    for a, b in blocks:
        d.wall(_block(rng, (a, by[0], b, by[1]), t))
    cx = [xl + wl / 2] + [b + wm / 2 for _, b in blocks[:-1]] + [xr - wr / 2]
    cy = (yb + wb / 2, yt - wt / 2)
    start = (mm(cx[0] + rng.uniform(0.6, 1.0)), mm(cy[0]))
    d.start = [start[0], start[1], 0.0]
    d.route = _cut_corners(start, _ring_corners(cx, cy))
    ring = "two blocks (a figure eight)" if len(blocks) == 2 else "one block"
    d.about = (f"loop {W:g} m x {H:g} m: {min(wl, wr, wb, wt, wm):.2f}-{max(wl, wr, wb, wt, wm):.2f} m "
               f"corridors around {ring}, route back to the start")
    return d


def _block(rng: np.random.Generator, faces: tuple, t: float) -> list:
    """Centre line of an inner block with faces (x0, y0, x1, y1), notched inwards here and
    there (a notch widens the corridor beside it)."""
    c = (faces[0] + t / 2, faces[1] + t / 2, faces[2] - t / 2, faces[3] - t / 2)
    jogs = []
    for side in range(4):
        if rng.random() < 0.3:
            lo, hi = (c[0], c[2]) if side % 2 == 0 else (c[1], c[3])
            across = (c[3] - c[1]) if side % 2 == 0 else (c[2] - c[0])
            # 0.4 m from the corners: notches on two sides of a corner never meet
            jogs.append(_jog(rng, side, (lo + 0.4, hi - 0.4), min(0.3, (across - 2 * t) / 3)))
    return _ring(*c, [j for j in jogs if j])


def _jog(rng: np.random.Generator, side: int, span: tuple[float, float], most: float):
    """(side, lo, hi, depth): a notch 0.5-2 m long inside `span` (world coordinate along the
    side), 0.1-`most` m deep; None when it does not fit."""
    room = span[1] - span[0]
    if room < 0.5 or most < 0.1:
        return None
    length = rng.uniform(0.5, min(2.0, room))
    lo = rng.uniform(span[0], span[1] - length)
    return side, mm(lo), mm(lo + length), mm(rng.uniform(0.1, most))


def _ring(x0: float, y0: float, x1: float, y1: float, jogs) -> list:
    """Closed polyline of a rectangle, counter-clockwise from (x0, y0), with notches: jogs
    (side 0-3 = bottom, right, top, left; lo, hi along the side's axis; depth inwards)."""
    corners = np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], dtype=float)
    pts = []
    for side in range(4):
        p, q = corners[side], corners[(side + 1) % 4]
        u = (q - p) / np.linalg.norm(q - p)
        inward = np.array([-u[1], u[0]])
        axis = side % 2
        pts.append(p)
        for _, lo, hi, depth in (j for j in jogs if j[0] == side):
            a, b = sorted(((lo - p[axis]) * u[axis], (hi - p[axis]) * u[axis]))
            pts += [p + u * a, p + u * a + inward * depth, p + u * b + inward * depth, p + u * b]
    return pts + [corners[0]]


def _ring_corners(cx: list[float], cy: tuple[float, float]) -> list[tuple[float, float]]:
    """Corners of the drive on the corridor centre lines (x: left, [middle,] right; y: bottom,
    top), from the bottom-left corridor heading +x: once round one block, or a figure eight
    (the left loop counter-clockwise, then the right loop clockwise, up the middle both times)."""
    (b, t) = cy
    if len(cx) == 2:
        return [(cx[1], b), (cx[1], t), (cx[0], t), (cx[0], b)]
    left, mid, right = cx
    return [(mid, b), (mid, t), (left, t), (left, b), (mid, b), (mid, t), (right, t), (right, b)]


def _cut_corners(start, corners) -> list[list[float]]:
    """Waypoints start -> corners -> start with each corner replaced by a chord _CUT m along
    both legs (pure pursuit follows those without stopping); the last one is the start."""
    pts = [np.asarray(p, dtype=float) for p in [start, *corners, start]]
    out = []
    for a, b, c in zip(pts[:-2], pts[1:-1], pts[2:]):
        u, v = (b - a) / np.linalg.norm(b - a), (c - b) / np.linalg.norm(c - b)
        out += [b - u * _CUT, b + v * _CUT]
    return [xy(p) for p in out] + [xy(start)]


RECIPES = {"office": _office, "warehouse": _warehouse, "hall": _hall, "loop": _loop}
