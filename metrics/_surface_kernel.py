"""Surface form of the grid portion: which occupied cells touch a wall surface, and which
stretches of the surfaces some occupied cell covers. A numba kernel and a numpy reference.

Everything is in the estimate's map coordinates (cell units: cell (r, c) is the closed square
[c, c+1] x [r, r+1]). A cell touches a surface segment when the distance between its square
and the segment is <= d (the tolerance in cells); a point of a segment is covered when it lies
within d of the square of an occupied cell. The points of a segment within d of one square
form one interval of its parameter (the distance to a convex set along a line is convex): the
union of the intervals of the segment against the square widened by d in x, in y, and the
four discs of radius d at its corners.

surface_match: compiled; surface_match_ref: the same statement in vectorised numpy (per
segment, over every cell of its bounding box), for tests.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["surface_match", "surface_match_ref"]


@njit(cache=True, nogil=True)
def _clip_box(x0, y0, dx, dy, xmin, xmax, ymin, ymax):
    """Liang-Barsky: parameter interval (t0, t1) of p(t) = (x0, y0) + t (dx, dy), t in [0, 1],
    inside the closed box; t0 > t1 when there is none."""
    t0 = 0.0
    t1 = 1.0
    for k in range(4):
        if k == 0:
            p, q = -dx, x0 - xmin
        elif k == 1:
            p, q = dx, xmax - x0
        elif k == 2:
            p, q = -dy, y0 - ymin
        else:
            p, q = dy, ymax - y0
        if p == 0.0:
            if q < 0.0:
                return 1.0, 0.0
        else:
            r = q / p
            if p < 0.0:
                if r > t0:
                    t0 = r
            elif r < t1:
                t1 = r
    return t0, t1


@njit(cache=True, nogil=True)
def _clip_disc(x0, y0, dx, dy, cx, cy, d):
    """Parameter interval of p(t), t in [0, 1], within distance d of (cx, cy)."""
    a = dx * dx + dy * dy
    fx = x0 - cx
    fy = y0 - cy
    c = fx * fx + fy * fy - d * d
    if a == 0.0:
        return (0.0, 1.0) if c <= 0.0 else (1.0, 0.0)
    b = fx * dx + fy * dy
    disc = b * b - a * c
    if disc < 0.0:
        return 1.0, 0.0
    s = math.sqrt(disc)
    return max(0.0, (-b - s) / a), min(1.0, (-b + s) / a)


@njit(cache=True, nogil=True)
def _near_interval(x0, y0, dx, dy, c, r, d):
    """Parameter interval of the points of the segment within d of cell (r, c)'s square."""
    lo, hi = np.inf, -np.inf
    a, b = _clip_box(x0, y0, dx, dy, c - d, c + 1.0 + d, r, r + 1.0)
    if a <= b:
        lo, hi = a, b
    a, b = _clip_box(x0, y0, dx, dy, c, c + 1.0, r - d, r + 1.0 + d)
    if a <= b:
        lo, hi = min(lo, a), max(hi, b)
    if d > 0.0:
        for k in range(4):
            a, b = _clip_disc(x0, y0, dx, dy, c + (k & 1), r + (k >> 1), d)
            if a <= b:
                lo, hi = min(lo, a), max(hi, b)
    return lo, hi


@njit(cache=True, nogil=True)
def _room_for(buf, n):
    """buf, or a copy twice its length when its n rows are all used."""
    if n < buf.shape[0]:
        return buf
    bigger = np.empty((2 * n, buf.shape[1]))
    for i in range(n):          # element copies: a slice assignment compiles numba's error
        for j in range(buf.shape[1]):   # formatting, seconds of every cold start
            bigger[i, j] = buf[i, j]
    return bigger


@njit(cache=True, nogil=True)
def _sift(buf, root, end):
    """Heap sort's sift-down of row `root` in buf[:end] by column 0."""
    while 2 * root + 1 < end:
        child = 2 * root + 1
        if child + 1 < end and buf[child + 1, 0] > buf[child, 0]:
            child += 1
        if buf[root, 0] >= buf[child, 0]:
            return
        for j in range(buf.shape[1]):
            buf[root, j], buf[child, j] = buf[child, j], buf[root, j]
        root = child


@njit(cache=True, nogil=True)
def _sort_rows(buf, m):
    """Sort buf[:m] in place by column 0 (heap sort: numba's np.argsort compiles a quicksort,
    about two seconds of every cold start)."""
    for root in range(m // 2 - 1, -1, -1):
        _sift(buf, root, m)
    for end in range(m - 1, 0, -1):
        for j in range(buf.shape[1]):
            buf[0, j], buf[end, j] = buf[end, j], buf[0, j]
        _sift(buf, 0, end)


@njit(cache=True, nogil=True)
def surface_match(segments, occupied, d):
    """Touching cells and covered stretches.

    segments: (S, 4) x0, y0, x1, y1 in map coordinates (cells); occupied: (rows, cols) bool;
    d: tolerance in cells (>= 0). Returns tp (rows, cols) bool (occupied cells within d of a
    segment) and intervals (M, 3) float: segment index, t0, t1 of the merged parameter
    intervals of each segment that occupied cells cover, in segment order.
    """
    rows, cols = occupied.shape
    tp = np.zeros((rows, cols), dtype=np.bool_)
    out = np.empty((64, 3))
    n = 0
    buf = np.empty((256, 2))
    for s in range(segments.shape[0]):
        x0 = segments[s, 0]
        y0 = segments[s, 1]
        dx = segments[s, 2] - x0
        dy = segments[s, 3] - y0
        c_lo = max(0, int(math.floor(min(x0, x0 + dx) - d)) - 1)
        c_hi = min(cols - 1, int(math.floor(max(x0, x0 + dx) + d)) + 1)
        r_lo = max(0, int(math.floor(min(y0, y0 + dy) - d)) - 1)
        r_hi = min(rows - 1, int(math.floor(max(y0, y0 + dy) + d)) + 1)
        m = 0
        for r in range(r_lo, r_hi + 1):
            for c in range(c_lo, c_hi + 1):
                if not occupied[r, c]:
                    continue
                lo, hi = _near_interval(x0, y0, dx, dy, c, r, d)
                if lo > hi:
                    continue
                tp[r, c] = True
                buf = _room_for(buf, m)
                buf[m, 0] = lo
                buf[m, 1] = hi
                m += 1
        if m == 0:
            continue
        _sort_rows(buf, m)
        cur_lo = buf[0, 0]
        cur_hi = buf[0, 1]
        for k in range(1, m + 1):
            if k < m and buf[k, 0] <= cur_hi:
                cur_hi = max(cur_hi, buf[k, 1])
                continue
            out = _room_for(out, n)       # close the merged interval [cur_lo, cur_hi]
            out[n, 0] = s
            out[n, 1] = cur_lo
            out[n, 2] = cur_hi
            n += 1
            if k < m:
                cur_lo = buf[k, 0]
                cur_hi = buf[k, 1]
    return tp, out[:n].copy()


def surface_match_ref(segments: np.ndarray, occupied: np.ndarray, d: float):
    """Reference for surface_match (same arguments and results): per segment, the interval of
    every occupied cell of its bounding box from the five pieces (two widened boxes, four
    discs) in vectorised numpy, then merged."""
    segments = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    rows, cols = occupied.shape
    tp = np.zeros((rows, cols), bool)
    out = []
    for s, (x0, y0, x1, y1) in enumerate(segments):
        dx, dy = x1 - x0, y1 - y0
        rr, cc = np.nonzero(occupied)
        near = ((cc >= min(x0, x1) - d - 1) & (cc <= max(x0, x1) + d + 1)
                & (rr >= min(y0, y1) - d - 1) & (rr <= max(y0, y1) + d + 1))
        rr, cc = rr[near].astype(float), cc[near].astype(float)
        pieces = [_slab(x0, y0, dx, dy, cc - d, cc + 1 + d, rr, rr + 1),
                  _slab(x0, y0, dx, dy, cc, cc + 1, rr - d, rr + 1 + d)]
        if d > 0:
            pieces += [_disc(x0, y0, dx, dy, cc + i, rr + j, d) for i in (0, 1) for j in (0, 1)]
        lo = np.min([np.where(a <= b, a, np.inf) for a, b in pieces], axis=0)
        hi = np.max([np.where(a <= b, b, -np.inf) for a, b in pieces], axis=0)
        hit = lo <= hi
        tp[rr[hit].astype(int), cc[hit].astype(int)] = True
        spans = sorted(zip(lo[hit], hi[hit]))
        merged: list[list[float]] = []
        for a, b in spans:
            if merged and a <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], b)
            else:
                merged.append([a, b])
        out += [[s, a, b] for a, b in merged]
    return tp, np.asarray(out, dtype=np.float64).reshape(-1, 3)


def _slab(x0, y0, dx, dy, xmin, xmax, ymin, ymax):
    """Vectorised parameter intervals of the segment inside boxes (arrays of bounds)."""
    t0 = np.zeros(len(xmin))
    t1 = np.ones(len(xmin))
    for p, q in ((-dx, x0 - xmin), (dx, xmax - x0), (-dy, y0 - ymin), (dy, ymax - y0)):
        if p == 0:
            t1 = np.where(q < 0, -1.0, t1)
        else:
            r = q / p
            if p < 0:
                t0 = np.maximum(t0, r)
            else:
                t1 = np.minimum(t1, r)
    return t0, t1


def _disc(x0, y0, dx, dy, cx, cy, d):
    """Vectorised parameter intervals of the segment within d of the points (cx, cy)."""
    a = dx * dx + dy * dy
    fx, fy = x0 - cx, y0 - cy
    c = fx * fx + fy * fy - d * d
    if a == 0:
        inside = c <= 0
        return np.where(inside, 0.0, 1.0), np.where(inside, 1.0, 0.0)
    b = fx * dx + fy * dy
    disc = b * b - a * c
    s = np.sqrt(np.maximum(disc, 0.0))
    lo = np.maximum(0.0, (-b - s) / a)
    hi = np.minimum(1.0, (-b + s) / a)
    return np.where(disc >= 0, lo, 1.0), np.where(disc >= 0, hi, 0.0)
