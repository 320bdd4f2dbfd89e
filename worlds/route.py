"""A covering route for worlds whose YAML gives none.

Method (an art-gallery style viewpoint plan, then a travelling-salesman order):
 1. the robot's space: ground-truth free cells whose centre is at least the robot radius
    (+1 cm) from the solid, in the start's component, 8-connected; each edge costs its
    length times a clearance penalty that grows as the cell nears `clearance` m from a
    wall, so paths keep to the middle of corridors where they can;
 2. candidate viewpoints on a lattice (`spacing` m) of cells at least `clearance` m from
    walls (closer cells join only if some wall cell is seen from no other candidate);
 3. greedy set cover: repeatedly take the candidate that sees the most wall cells not yet
    seen (within `max_range`, by exact ray casting as in worlds.coverage) until every wall
    cell seen by any candidate is covered;
 4. order: nearest neighbour from the start, improved by 2-opt and or-opt moves on the
    shortest-path distances (an open path, the start fixed);
 5. join consecutive viewpoints by shortest paths on the grid graph (Dijkstra,
    scipy.sparse.csgraph), smooth by line-of-sight shortcuts that keep the clearance, and
    cut sharp corners by short chords (pure pursuit follows those without stopping).
"""
from __future__ import annotations

import numpy as np
import shapely

from worlds.coverage import resample_path
from worlds.grid import Grid
from worlds.limits import max_route_cells
from worlds.model import ROBOT_RADIUS, World
from worlds.raster import rasterize
from worlds.visibility import beam_angles, cast_rays, hit_cells
from worlds.yamlio import InputError

__all__ = ["plan_route", "route_for"]


def route_for(world: World) -> np.ndarray:
    """(K, 2) waypoints: the YAML route if the world gives one, else plan_route(world)."""
    if world.route is not None:
        return np.asarray(world.route, dtype=np.float64).reshape(-1, 2).copy()
    return plan_route(world)


class _RobotGraph:
    """Free cells the robot's centre may occupy, as a weighted 8-connected graph."""

    def __init__(self, world: World, truth: Grid, clearance: float):
        self.truth = truth
        free = truth.free()
        rows, cols = np.nonzero(free)
        xy = truth.cell_to_world(rows, cols)
        dist = shapely.distance(world.solid, shapely.points(xy))
        ok = dist >= ROBOT_RADIUS + 0.01
        self.rows, self.cols, self.xy, self.dist = rows[ok], cols[ok], xy[ok], dist[ok]
        index = np.full(truth.shape, -1, dtype=np.int64)
        index[self.rows, self.cols] = np.arange(len(self.rows))
        self.index = index
        n = len(self.rows)
        res = truth.resolution
        # the penalty grows to 1 + 8 = 9x at the robot radius: prefer the corridor middle
        pen = 1.0 + 8.0 * np.clip((clearance - self.dist) / (clearance - ROBOT_RADIUS), 0.0, 1.0) ** 2
        src, dst, w = [], [], []
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            r2, c2 = self.rows + dr, self.cols + dc
            inside = (r2 >= 0) & (r2 < truth.rows) & (c2 >= 0) & (c2 < truth.cols)
            j = np.full(n, -1)
            j[inside] = index[r2[inside], c2[inside]]
            m = j >= 0
            i = np.nonzero(m)[0]
            length = res * np.hypot(dr, dc)
            src.append(i)
            dst.append(j[m])
            w.append(length * 0.5 * (pen[i] + pen[j[m]]))
        src, dst, w = np.concatenate(src), np.concatenate(dst), np.concatenate(w)
        from scipy import sparse   # imported here: scipy's import is slow, only the planner needs it
        self.matrix = sparse.coo_matrix((np.r_[w, w], (np.r_[src, dst], np.r_[dst, src])),
                                        shape=(n, n)).tocsr()

    def node_of(self, xy: np.ndarray) -> int:
        """The graph node nearest to world point xy."""
        return int(np.argmin(np.hypot(self.xy[:, 0] - xy[0], self.xy[:, 1] - xy[1])))

    def component(self, node: int) -> np.ndarray:
        """Bool mask of nodes connected to `node`."""
        from scipy.sparse import csgraph
        _, labels = csgraph.connected_components(self.matrix, directed=False)
        return labels == labels[node]


def _visible_sets(world: World, truth: Grid, points: np.ndarray, max_range: float,
                  n_beams: int = 2048) -> list[np.ndarray]:
    """For each point, the flat indices of occupied truth cells a beam from it ends in."""
    occ = truth.occupied()
    angles = beam_angles(n_beams)
    out = []
    for i in range(0, len(points), 64):
        chunk = points[i:i + 64]
        ranges = cast_rays(world.segments, chunk, angles, max_range)
        for k in range(len(chunk)):
            r, c = hit_cells(truth, chunk[k:k + 1], angles, ranges[k:k + 1])
            keep = occ[r, c]
            out.append(np.unique(r[keep] * truth.cols + c[keep]))
    return out


def _greedy_cover(sets: list[np.ndarray], universe: np.ndarray) -> list[int]:
    """Indices of sets chosen greedily (most new elements first) until `universe` is covered."""
    left = set(universe.tolist())
    as_sets = [set(s.tolist()) for s in sets]
    chosen = []
    while left:
        gains = [len(s & left) for s in as_sets]
        best = int(np.argmax(gains))
        if gains[best] == 0:
            break
        chosen.append(best)
        left -= as_sets[best]
    return chosen


def _tour_cost(dist: np.ndarray, tour: list[int]) -> float:
    return float(sum(dist[a, b] for a, b in zip(tour[:-1], tour[1:])))


def _order(dist: np.ndarray) -> list[int]:
    """Open tour over the nodes of a (K+1, K+1) distance matrix starting at node 0:
    nearest neighbour, then 2-opt reversals and or-opt moves (a run of 1-3 nodes moved
    elsewhere, either way round) until neither shortens it."""
    k = len(dist)
    tour = [0]
    todo = set(range(1, k))
    while todo:
        last = tour[-1]
        nxt = min(todo, key=lambda j: (dist[last, j], j))
        tour.append(nxt)
        todo.remove(nxt)
    cost = _tour_cost(dist, tour)
    improved = True
    while improved:
        improved = False
        for i in range(1, k - 1):                      # 2-opt: reverse tour[i..j]
            for j in range(i + 1, k):
                cand = tour[:i] + tour[i:j + 1][::-1] + tour[j + 1:]
                c = _tour_cost(dist, cand)
                if c < cost - 1e-9:
                    tour, cost, improved = cand, c, True
        for n in (1, 2, 3):                            # or-opt: move tour[i:i+n]
            for i in range(1, k - n + 1):
                run, rest = tour[i:i + n], tour[:i] + tour[i + n:]
                for j in range(1, len(rest) + 1):
                    for piece in (run, run[::-1]):
                        cand = rest[:j] + piece + rest[j:]
                        c = _tour_cost(dist, cand)
                        if c < cost - 1e-9:
                            tour, cost, improved = cand, c, True
                            break
                    else:
                        continue
                    break
    return tour


def _shortcut(path: np.ndarray, world: World, clearance: float) -> np.ndarray:
    """Drop vertices while the straight line between kept ones stays as far from walls as
    the path it replaces (up to `clearance` m, less 2 cm)."""
    solid = world.solid
    shapely.prepare(solid)
    vdist = shapely.distance(solid, shapely.points(path))

    def clear(i, j):
        need = min(clearance, float(vdist[i:j + 1].min())) - 0.02
        pts = resample_path(np.vstack([path[i], path[j]]), 0.05)
        return bool(np.all(shapely.distance(solid, shapely.points(pts)) >= need))

    out = [path[0]]
    i = 0
    while i < len(path) - 1:
        # farthest vertex reachable in a straight line (binary steps keep this fast)
        lo, hi = i + 1, len(path) - 1
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if clear(i, mid):
                lo = mid
            else:
                hi = mid - 1
        out.append(path[lo])
        i = lo
    return np.asarray(out)


def _chamfer(path: np.ndarray, world: World, keep: np.ndarray, cut: float = 0.2,
             min_clear: float = ROBOT_RADIUS + 0.05) -> np.ndarray:
    """Cut each corner sharper than 30 degrees by a chord `cut` m along both legs (at most a
    third of each leg), where the chord keeps min_clear m from walls: gentler turns for
    pure pursuit. Vertices flagged in `keep` (the viewpoints: what they see depends on
    standing exactly there) stay."""
    solid = world.solid
    out = [path[0]]
    for i in range(1, len(path) - 1):
        a, b, c = out[-1], path[i], path[i + 1]
        u, v = b - a, c - b
        lu, lv = np.hypot(*u), np.hypot(*v)
        if lu < 1e-9 or lv < 1e-9:
            continue
        turn = np.arccos(np.clip(np.dot(u, v) / (lu * lv), -1.0, 1.0))
        d = min(cut, lu / 3.0, lv / 3.0)
        p, q = b - u / lu * d, b + v / lv * d
        if (not keep[i] and turn > np.radians(30)
                and shapely.LineString([p, q]).distance(solid) >= min_clear):
            out.extend([p, q])
        else:
            out.append(b)
    out.append(path[-1])
    return np.asarray(out)


def plan_route(world: World, max_range: float = 3.0, clearance: float = 0.3,
               spacing: float = 0.2) -> np.ndarray:
    """(K, 2) waypoints (m) from the start that let a lidar of `max_range` m see every wall
    cell of the ground truth that can be seen from the robot's reachable space.

    clearance: preferred distance (m) of the route from walls; spacing: candidate lattice (m).
    """
    # the free space bounds the planner's graph (nodes, 8 edges each): checked from the geometry
    # before the true map of a huge world is even made
    xmin, ymin, xmax, ymax = world.bounds
    free = int(((xmax - xmin) * (ymax - ymin) - world.solid.area) / world.resolution ** 2)
    if free > max_route_cells():
        raise InputError(f"{world.source or world.name}: route: the free space is about {free:,} cells, more "
                         f"than the route planner takes on ({max_route_cells():,}, "
                         "SLAM_BENCH_MAX_ROUTE_CELLS); give the world a route")
    truth = rasterize(world)
    graph = _RobotGraph(world, truth, clearance)
    if len(graph.xy) == 0:
        raise InputError(f"{world.source or world.name}: route: no room to plan a route (no cell "
                         f"of the free space is {ROBOT_RADIUS + 0.01:.3f} m from the walls)")
    start_node = graph.node_of(world.start[:2])
    comp = graph.component(start_node)
    step = max(1, int(round(spacing / truth.resolution)))
    lattice = (graph.rows % step == 0) & (graph.cols % step == 0) & comp
    preferred = lattice & (graph.dist >= clearance)
    fallback = lattice & ~preferred
    cand = np.r_[np.nonzero(preferred)[0], np.nonzero(fallback)[0]]
    sets = _visible_sets(world, truth, graph.xy[cand], max_range)
    n_pref = int(preferred.sum())
    pref_universe = np.unique(np.concatenate(sets[:n_pref])) if n_pref else np.zeros(0, int)
    chosen = _greedy_cover(sets[:n_pref], pref_universe)
    # wall cells visible only from close to a wall: cover them from the fallback candidates
    all_universe = np.unique(np.concatenate(sets)) if sets else np.zeros(0, int)
    rest = np.setdiff1d(all_universe, pref_universe)
    if len(rest):
        extra = _greedy_cover([np.intersect1d(s, rest) for s in sets[n_pref:]], rest)
        chosen += [n_pref + e for e in extra]
    views = cand[chosen]
    nodes = np.r_[start_node, views]
    from scipy.sparse import csgraph
    dist, pred = csgraph.dijkstra(graph.matrix, directed=False, indices=nodes, return_predecessors=True)
    tour = _order(dist[:, nodes])
    # join the viewpoints in order; each leg is smoothed on its own so viewpoints stay
    out = [np.asarray(world.start[:2], dtype=np.float64)]
    view = [True]
    for a, b in zip(tour[:-1], tour[1:]):
        chain = []
        n = nodes[b]
        while n != nodes[a] and n >= 0:
            chain.append(n)
            n = pred[a, n]
        if not chain:
            continue
        leg = np.vstack([out[-1], graph.xy[np.asarray(chain[::-1])]])
        smooth = _shortcut(leg, world, clearance)[1:]
        out.extend(smooth)
        view.extend([False] * (len(smooth) - 1) + [True])
    if len(out) == 1:
        return np.asarray([graph.xy[start_node]])
    return _chamfer(np.asarray(out), world, np.asarray(view))[1:]
