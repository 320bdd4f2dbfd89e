"""Correlative scan matching kernels (Olson 2009; Hess, Kohler, Rapp, Andor 2016, Sec. V).

A candidate pose is (k, dx, dy): rotation k of a list of pre-rotated, pre-discretised scans,
then an integer cell shift. Its score is the mean grid value under the scan's points
(cells outside the grid count 0).

- `max_grids`: Cartographer's precomputation grids. Level h holds, at each cell, the maximum
  over the 2^h x 2^h block of cells starting there, so the score of one candidate at level h
  bounds the score of every candidate in the block of shifts it stands for.
- `bnb_search`: the branch-and-bound of the fast correlative scan matcher: all rotations at
  the coarsest level, then depth-first into the most promising blocks, pruning every block
  whose bound is not above the best leaf found (or min_score).
- `score_candidates`: every candidate at the finest level (the real-time correlative matcher
  and the brute-force reference of the branch and bound).

Each compiled kernel has a plain numpy reference (`*_ref`) written independently, for tests.
Storage convention of the max grids: one (D+1, rows+pad, cols+pad) float32 array with
pad = 2^D - 1; grid cell (r, c) sits at [h, r+pad, c+pad], so blocks reaching the grid from
below or from the left are stored too, and a margin of zero cells around them, which
bnb_search reads through (bnb_margin), so a shifted point needs no bounds check, and sums the four
children of a block in one pass over the points.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["max_grids", "max_grids_ref", "bnb_margin", "bnb_search", "score_candidates", "score_candidates_ref",
           "best_candidate_ref", "discretize_rotations", "discretize_rotations_ref"]


@njit(cache=True, nogil=True)
def discretize_rotations(points, x, y, yaws, ox, oy, res):
    """(K, N, 2) int32 (col, row) cells of the points (N, 2, robot frame) with the robot at
    (x, y) and each yaw (K,), on the lattice of origin (ox, oy) and cell size res: the
    pre-rotated scans every candidate of a correlative search shifts by whole cells."""
    K = yaws.shape[0]
    n = points.shape[0]
    out = np.empty((K, n, 2), np.int32)
    qx = points[:, 0].copy()
    qy = points[:, 1].copy()
    fx = np.empty(n)
    fy = np.empty(n)
    for k in range(K):
        c = np.cos(yaws[k])
        s = np.sin(yaws[k])
        # contiguous float loops first, so the compiler vectorises the divisions
        for p in range(n):
            fx[p] = np.floor((x + c * qx[p] - s * qy[p] - ox) / res)
            fy[p] = np.floor((y + s * qx[p] + c * qy[p] - oy) / res)
        for p in range(n):
            out[k, p, 0] = np.int32(fx[p])
            out[k, p, 1] = np.int32(fy[p])
    return out


def discretize_rotations_ref(points, x, y, yaws, ox, oy, res) -> np.ndarray:
    """Numpy reference of discretize_rotations: all rotations at once by broadcasting."""
    c, s = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
    wx = x + c * points[None, :, 0] - s * points[None, :, 1]
    wy = y + s * points[None, :, 0] + c * points[None, :, 1]
    return np.stack([np.floor((wx - ox) / res), np.floor((wy - oy) / res)], axis=2).astype(np.int32)


@njit(cache=True, nogil=True)
def max_grids(prob, depth, margin):
    """prob: (R, C) float grid values (NaN not allowed; use 0 for unknown); depth: D >= 0;
    margin: zero cells added on every side (bnb_search reads the levels through one).

    Returns (D+1, R+pad+2*margin, C+pad+2*margin) float32 with pad = 2^D - 1;
    [h, i+margin, j+margin] = max of prob over rows i-pad .. i-pad+2^h-1 and cols
    j-pad .. j-pad+2^h-1 (0 outside prob).
    """
    rows, cols = prob.shape
    pad = (1 << depth) - 1
    m0 = margin
    out = np.zeros((depth + 1, rows + pad + 2 * m0, cols + pad + 2 * m0), np.float32)
    for r in range(rows):
        for c in range(cols):
            out[0, r + pad + m0, c + pad + m0] = prob[r, c]
    R = rows + pad
    C = cols + pad
    for h in range(1, depth + 1):
        w = 1 << (h - 1)
        for i in range(R):
            for j in range(C):
                m = out[h - 1, m0 + i, m0 + j]
                if i + w < R:
                    v = out[h - 1, m0 + i + w, m0 + j]
                    if v > m:
                        m = v
                    if j + w < C:
                        v = out[h - 1, m0 + i + w, m0 + j + w]
                        if v > m:
                            m = v
                if j + w < C:
                    v = out[h - 1, m0 + i, m0 + j + w]
                    if v > m:
                        m = v
                out[h, m0 + i, m0 + j] = m
    return out


def max_grids_ref(prob: np.ndarray, depth: int) -> np.ndarray:
    """Numpy reference of max_grids: each level by an explicit max over shifted copies."""
    rows, cols = prob.shape
    pad = (1 << depth) - 1
    big = np.zeros((rows + 2 * pad + 1, cols + 2 * pad + 1), np.float32)
    big[pad:pad + rows, pad:pad + cols] = prob
    out = np.zeros((depth + 1, rows + pad, cols + pad), np.float32)
    for h in range(depth + 1):
        w = 1 << h
        level = np.zeros((rows + pad, cols + pad), np.float32)
        for a in range(w):
            for b in range(w):
                level = np.maximum(level, big[a:a + rows + pad, b:b + cols + pad])
        out[h] = level
    return out


@njit(cache=True, nogil=True)
def score_candidates(grid, cells, wx, wy):
    """Scores of all candidates at the finest level.

    grid: (R, C) float values; cells: (K, P, 2) int32 (col, row) of each point at each
    rotation for shift (0, 0); wx, wy: shift windows in cells. Returns (K, 2wy+1, 2wx+1)
    float64 mean values, [k, dy+wy, dx+wx].
    """
    K, n = cells.shape[0], cells.shape[1]
    R, C = grid.shape
    out = np.zeros((K, 2 * wy + 1, 2 * wx + 1))
    for k in range(K):
        for p in range(n):
            c0 = cells[k, p, 0]
            r0 = cells[k, p, 1]
            for a in range(2 * wy + 1):
                i = r0 + a - wy
                if i < 0 or i >= R:
                    continue
                for b in range(2 * wx + 1):
                    j = c0 + b - wx
                    if 0 <= j < C:
                        out[k, a, b] += grid[i, j]
    return out / n


def score_candidates_ref(grid: np.ndarray, cells: np.ndarray, wx: int, wy: int) -> np.ndarray:
    """Numpy reference of score_candidates: pad the grid, gather per shift."""
    K, n = cells.shape[:2]
    padded = np.zeros((grid.shape[0] + 2 * wy + 2, grid.shape[1] + 2 * wx + 2))
    out = np.zeros((K, 2 * wy + 1, 2 * wx + 1))
    for dy in range(-wy, wy + 1):
        for dx in range(-wx, wx + 1):
            r = cells[:, :, 1] + dy
            c = cells[:, :, 0] + dx
            ok = (r >= 0) & (r < grid.shape[0]) & (c >= 0) & (c < grid.shape[1])
            vals = np.where(ok, grid[np.clip(r, 0, grid.shape[0] - 1), np.clip(c, 0, grid.shape[1] - 1)], 0.0)
            out[:, dy + wy, dx + wx] = vals.sum(axis=1) / n
    del padded
    return out


def best_candidate_ref(grid: np.ndarray, cells: np.ndarray, wx: int, wy: int,
                       exclude=(0, 0, -1)) -> tuple[int, int, int, float]:
    """Brute force: (k, dx, dy, score) of the best candidate, by scoring all of them;
    exclude (x, y, r): shifts with |dx - x| <= r and |dy - y| <= r are left out (r < 0: none)."""
    s = score_candidates_ref(np.asarray(grid, np.float32).astype(np.float64), cells, wx, wy)
    ex, ey, er = exclude
    if er >= 0:
        dxs = np.arange(-wx, wx + 1)[None, None, :]
        dys = np.arange(-wy, wy + 1)[None, :, None]
        s = np.where((np.abs(dxs - ex) <= er) & (np.abs(dys - ey) <= er), -np.inf, s)
    k, a, b = np.unravel_index(int(np.argmax(s)), s.shape)
    return int(k), int(b - wx), int(a - wy), float(s[k, a, b])


@njit(cache=True, nogil=True)
def _start_level(depth, wx, wy):
    """The coarsest level whose blocks are not all larger than the window: above it each
    block has one child in the window and its bound is only looser."""
    h0 = depth
    while h0 > 0 and (1 << (h0 - 1)) >= 2 * max(wx, wy) + 1:
        h0 -= 1
    return h0


def bnb_margin(depth: int, wx: int, wy: int) -> int:
    """Zero cells bnb_search needs on every side of max_grids' levels (depth D, shift windows
    wx, wy cells): a point whose shifted cells reach the grid has all of them in the array."""
    return 2 * max(wx, wy) + ((1 << _start_level(depth, wx, wy)) >> 1) + 1


@njit(cache=True, nogil=True)
def _sum(flat, base, n, off):
    s = 0.0
    for p in range(n):
        s += flat[np.uint64(base[p] + off)]
    return s


@njit(cache=True, nogil=True)
def _sum_children(flat, base, n, off, half, stride, out):
    """out[a * 2 + b] = sum of flat[base + off + a * half * stride + b * half] over the points:
    the four children of a block in one pass (four independent sums in point order)."""
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    up = half * stride
    for p in range(n):
        # unsigned indices: numba then skips its negative-index wraparound on every read
        q = np.uint64(base[p] + off)
        s0 += flat[q]
        s1 += flat[q + np.uint64(half)]
        s2 += flat[q + np.uint64(up)]
        s3 += flat[q + np.uint64(up + half)]
    out[0] = s0
    out[1] = s1
    out[2] = s2
    out[3] = s3


@njit(cache=True, nogil=True)
def _sum_pair(flat, base, n, off, step, out):
    """out[0], out[1] = the sums of _sum at offsets off and off + step, in one pass."""
    s0 = 0.0
    s1 = 0.0
    for p in range(n):
        q = np.uint64(base[p] + off)
        s0 += flat[q]
        s1 += flat[q + np.uint64(step)]
    out[0] = s0
    out[1] = s1


@njit(cache=True, nogil=True)
def bnb_search(grids, margin, cells, wx, wy, min_score, ex_x, ex_y, ex_r):
    """Branch and bound over rotations and cell shifts (Hess et al. 2016, Algorithm 3).

    grids: from max_grids (depth D = grids.shape[0]-1) with a `margin` >= bnb_margin(D, wx, wy); cells: (K, P, 2) int32; wx, wy: shift
    windows (|dx| <= wx, |dy| <= wy); min_score: leaves must score above it; ex_x, ex_y, ex_r:
    shifts within ex_r cells (Chebyshev) of (ex_x, ex_y) are excluded (ex_r < 0: none), to
    find the best match elsewhere (an ambiguity check). No defaults on purpose: numba's fast
    dispatch does not serve calls that omit arguments (a type inference on every call).
    Returns (k, dx, dy, score); k = -1 when no candidate beats min_score.
    """
    D = grids.shape[0] - 1
    h0 = _start_level(D, wx, wy)
    if margin < 2 * max(wx, wy) + ((1 << h0) >> 1) + 1:
        raise ValueError("bnb_search: margin below bnb_margin")
    R = grids.shape[1]
    C = grids.shape[2]
    flat = grids.reshape(-1)
    org = (1 << D) - 1 + margin        # stored row / col of grid cell 0
    K = cells.shape[0]
    n = cells.shape[1]
    # Flat index of each point at shift (0, 0). A point whose shifted cells never reach the
    # grid reads a cell of the zero margin instead, whose shifts stay in the margin: it adds
    # +0.0, which leaves every sum as it was.
    reach = (1 << h0) >> 1
    span_i = np.uint64(R - 2 * wy - reach)     # positive: the margin check above
    span_j = np.uint64(C - 2 * wx - reach)
    zero = wy * C + wx
    base = np.empty((K, n), np.int64)
    cf = np.ascontiguousarray(cells).reshape(-1)
    bf = base.reshape(-1)
    for q in range(K * n):
        i = np.int64(cf[2 * q + 1]) + org
        j = np.int64(cf[2 * q]) + org
        # wy <= i < R - wy - reach and the same for j, as one unsigned compare each
        inside = (np.uint64(i - wy) < span_i) & (np.uint64(j - wx) < span_j)
        bf[q] = i * C + j if inside else zero
    step = 1 << h0
    nx = (2 * wx) // step + 1
    ny = (2 * wy) // step + 1
    n_top = K * nx * ny
    cap = n_top + 4 * (h0 + 1) + 8
    sk = np.empty(cap, np.int64)
    sx = np.empty(cap, np.int64)
    sy = np.empty(cap, np.int64)
    sh = np.empty(cap, np.int64)
    ss = np.empty(cap, np.float64)
    # Coarsest level: score every block, push in ascending order so the best pops first.
    tk = np.empty(n_top, np.int64)
    tx = np.empty(n_top, np.int64)
    ty = np.empty(n_top, np.int64)
    ts = np.empty(n_top, np.float64)
    m = 0
    for k in range(K):
        for a in range(ny):
            for b in range(nx):
                dx = -wx + b * step
                dy = -wy + a * step
                tk[m] = k
                tx[m] = dx
                ty[m] = dy
                ts[m] = _sum(flat, base[k], n, (h0 * R + dy) * C + dx) / n
                m += 1
    order = np.argsort(ts)
    top = 0
    for q in range(n_top):
        o = order[q]
        sk[top] = tk[o]
        sx[top] = tx[o]
        sy[top] = ty[o]
        sh[top] = h0
        ss[top] = ts[o]
        top += 1
    best_k, best_x, best_y = -1, 0, 0
    best = min_score
    ck = np.empty(4, np.int64)
    cx = np.empty(4, np.int64)
    cy = np.empty(4, np.int64)
    cs = np.empty(4, np.float64)
    four = np.empty(4, np.float64)
    while top > 0:
        top -= 1
        s = ss[top]
        if s <= best:
            continue
        k, dx, dy, h = sk[top], sx[top], sy[top], sh[top]
        if ex_r >= 0:
            size = (1 << h) - 1
            if dx >= ex_x - ex_r and dx + size <= ex_x + ex_r and dy >= ex_y - ex_r and dy + size <= ex_y + ex_r:
                continue        # the whole block lies in the excluded square
        if h == 0:
            best, best_k, best_x, best_y = s, k, dx, dy
            continue
        half = 1 << (h - 1)
        # only the children inside the window are summed
        off = ((h - 1) * R + dy) * C + dx
        right = dx + half <= wx
        upper = dy + half <= wy
        if right and upper:
            _sum_children(flat, base[k], n, off, half, C, four)
        elif right:
            _sum_pair(flat, base[k], n, off, half, four)
        elif upper:
            _sum_pair(flat, base[k], n, off, half * C, four)
            four[2] = four[1]
        else:
            four[0] = _sum(flat, base[k], n, off)
        nc = 0
        for a in range(2):
            for b in range(2):
                x = dx + b * half
                y = dy + a * half
                if x > wx or y > wy:
                    continue
                ck[nc] = k
                cx[nc] = x
                cy[nc] = y
                cs[nc] = four[2 * a + b] / n
                nc += 1
        # Push children worst first so the best child is explored next (depth first).
        for _ in range(nc):
            lo = -1
            for q in range(nc):
                if cs[q] >= -1e300 and (lo < 0 or cs[q] < cs[lo]):
                    lo = q
            sk[top] = ck[lo]
            sx[top] = cx[lo]
            sy[top] = cy[lo]
            sh[top] = h - 1
            ss[top] = cs[lo]
            top += 1
            cs[lo] = -1e301
    return best_k, best_x, best_y, best
