"""Surface form of the grid portion: kernel against its numpy reference, the fast path against
a brute force with shapely (no shared code), and the cases the form exists for."""
import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from metrics._surface_kernel import surface_match, surface_match_ref
from metrics.surface import _EDGE_EPS_CELLS, classify_surface, visible_surfaces
from worlds.grid import Grid
from worlds.load import world_from_dict
from worlds.raster import rasterize


@pytest.mark.kernel
@pytest.mark.parametrize("d", [0.0, 0.2, 0.4])
def test_kernel_matches_reference(d):
    rng = np.random.default_rng(7)
    for _ in range(60):
        occupied = rng.random((12, 14)) < 0.3
        segs = rng.uniform(-1, 15, (5, 4))
        segs[:2, 2] = segs[:2, 0] = np.round(segs[:2, 0])    # on cell edges
        segs[2, 3] = segs[2, 1] = np.round(segs[2, 1])
        segs[3, 2:] = segs[3, :2]                            # a point
        tp, iv = surface_match(segs, occupied, d)
        tp_ref, iv_ref = surface_match_ref(segs, occupied, d)
        np.testing.assert_array_equal(tp, tp_ref)
        np.testing.assert_allclose(iv, iv_ref, atol=1e-12)


def _brute_force(occupied: np.ndarray, grid: Grid, segments: np.ndarray, tau: float, step: float):
    """Precision and sensitivity by shapely: each occupied cell's square against the surfaces,
    and surface points every `step` m against the union of the squares."""
    rows, cols = np.nonzero(occupied)
    x0 = grid.origin[0] + cols * grid.resolution
    y0 = grid.origin[1] + rows * grid.resolution
    boxes = shapely.box(x0, y0, x0 + grid.resolution, y0 + grid.resolution)
    edge = _EDGE_EPS_CELLS * grid.resolution   # the kernel's "touching": within 1e-6 cell
    lines = shapely.multilinestrings([[s[:2], s[2:]] for s in segments])
    tp = shapely.distance(boxes, lines) <= tau + edge
    precision = tp.mean() if len(tp) else 0.0
    pts, weights = [], []
    for s in segments:
        length = math.hypot(s[2] - s[0], s[3] - s[1])
        n = max(1, int(math.ceil(length / step)))
        t = (np.arange(n) + 0.5) / n
        pts.append(s[:2] + t[:, None] * (s[2:] - s[:2]))
        weights.append(np.full(n, length / n))
    pts, weights = np.vstack(pts), np.concatenate(weights)
    union = shapely.union_all(boxes)
    covered = shapely.distance(shapely.points(pts), union) <= tau + edge
    return float(precision), float(weights[covered].sum() / weights.sum())


def _room_world(x0: float, y0: float, w: float, h: float, yaw: float, pillar: float | None):
    c, s = math.cos(yaw), math.sin(yaw)
    corners = [(x0 + c * u - s * v, y0 + s * u + c * v) for u, v in
               ((0, 0), (w, 0), (w, h), (0, h), (0, 0))]
    data = {"walls": {"thickness": 0.1, "polylines": [[list(p) for p in corners]]},
            "robot": {"start": [x0 + c * w / 2 - s * h / 4, y0 + s * w / 2 + c * h / 4, 0.0]}}
    if pillar is not None:
        data["obstacles"] = [{"circle": {"center": [x0 + c * w / 2 - s * 3 * h / 4,
                                                   y0 + s * w / 2 + c * 3 * h / 4],
                                         "radius": pillar, "sides": 16}}]
    return world_from_dict(data, where="room.yaml")


@settings(max_examples=25, deadline=None)
@given(x0=st.sampled_from([0.0, 0.05, 0.0137, 0.025]), y0=st.floats(-0.05, 0.05),
       w=st.floats(1.2, 2.0), h=st.floats(1.2, 2.0), yaw=st.sampled_from([0.0, 0.3, 0.785]),
       pillar=st.one_of(st.none(), st.floats(0.1, 0.2)), tau=st.sampled_from([0.0, 0.01, 0.02]),
       seed=st.integers(0, 1000), offset=st.sampled_from([0.0, 0.021, 0.05]))
def test_fast_path_matches_brute_force(x0, y0, w, h, yaw, pillar, tau, seed, offset):
    world = _room_world(x0, y0, w, h, yaw, pillar)
    segs = visible_surfaces(world)
    truth = rasterize(world)
    # an estimate on its own lattice: the truth's occupied cells, some dropped, a few added
    rng = np.random.default_rng(seed)
    grid = Grid(np.zeros_like(truth.prob), truth.resolution,
                truth.origin + [offset, -offset, 0.0])
    occ = truth.occupied() & (rng.random(truth.shape) < 0.8)
    occ |= rng.random(truth.shape) < 0.02
    grid.prob[occ] = 1.0
    c = classify_surface(grid, segs, (0.0, 0.0, 0.0), tau).counts
    step = 0.0005
    p, s = _brute_force(occ, grid, segs, tau, step)
    assert c["surface_precision"] == pytest.approx(p, abs=1e-12)
    # sampling misses at most a step at each end of each covered stretch
    assert c["surface_sensitivity"] == pytest.approx(s, abs=4 * step * len(segs) / c["surface_length_m"])


def test_perfect_map_scores_one_and_faces_on_cell_edges_touch_both_cells():
    # inner faces at x = 0 and y = 0 (cell edges) and at x = 2.03, y = 1.51 (inside cells)
    world = world_from_dict({"walls": {"thickness": 0.1, "polylines": [
        [[-0.05, -0.05], [2.08, -0.05], [2.08, 1.56], [-0.05, 1.56], [-0.05, -0.05]]]},
        "robot": {"start": [1.0, 0.7, 0.0]}}, where="room.yaml")
    truth = rasterize(world)
    segs = visible_surfaces(world)
    c = classify_surface(truth, segs, (0.0, 0.0, 0.0), 0.0).counts
    assert c["surface_precision"] == 1.0 and c["surface_sensitivity"] == pytest.approx(1.0)
    # the cells just on the free side of the x = 0 face touch it at tau = 0 too
    free_side = Grid(np.zeros_like(truth.prob), truth.resolution, truth.origin.copy())
    r, col = truth.world_to_cell(np.array([[0.025, 0.7]]))
    free_side.prob[r[0], col[0]] = 1.0
    assert classify_surface(free_side, segs, (0.0, 0.0, 0.0), 0.0).counts["surface_precision"] == 1.0


def test_wrong_maps_score_low():
    world = world_from_dict({"walls": {"thickness": 0.12, "polylines": [
        [[-0.075, -0.075], [3.075, -0.075], [3.075, 2.075], [-0.075, 2.075], [-0.075, -0.075]]]},
        "robot": {"start": [1.0, 1.0, 0.0]}}, where="room.yaml")
    truth = rasterize(world)
    segs = visible_surfaces(world)
    # the true map moved by one cell: walls across the move are wrong, walls along it right
    moved = Grid(truth.prob, truth.resolution, truth.origin + [truth.resolution, 0.0, 0.0])
    c = classify_surface(moved, segs, (0.0, 0.0, 0.0), 0.01).counts
    assert 0.5 < c["surface_precision"] < 0.7 and 0.5 < c["surface_sensitivity"] < 0.7
    # half the walls removed: sensitivity near 0.5, precision untouched
    half = truth.prob.copy()
    rows, cols = np.nonzero(truth.occupied())
    left = truth.cell_to_world(rows, cols)[:, 0] < 1.5
    half[rows[left], cols[left]] = 0.0
    c = classify_surface(Grid(half, truth.resolution, truth.origin), segs, (0.0, 0.0, 0.0), 0.01).counts
    assert c["surface_precision"] == 1.0 and c["surface_sensitivity"] == pytest.approx(0.5, abs=0.05)
    # an empty map
    empty = Grid(np.zeros_like(truth.prob), truth.resolution, truth.origin)
    c = classify_surface(empty, segs, (0.0, 0.0, 0.0), 0.01).counts
    assert c["surface_precision"] == 0.0 and c["surface_sensitivity"] == 0.0


def test_the_alignment_moves_the_surfaces_into_the_estimate():
    from slam.pose import inverse, transform_points
    corners = np.array([[0, 0], [2, 0], [2, 1.5], [0, 1.5], [0, 0]], float)
    world = world_from_dict({"walls": {"thickness": 0.1, "polylines": [corners.tolist()]},
                             "robot": {"start": [1.0, 0.7, 0.0]}}, where="room.yaml")
    segs = visible_surfaces(world)
    # the same room mapped in a frame moved by (0.3, -0.2, 0.1): the alignment brings it back
    pose = np.array([0.3, -0.2, 0.1])
    back = transform_points(inverse(pose), corners)
    start = transform_points(inverse(pose), np.array([[1.0, 0.7]]))[0]
    est = rasterize(world_from_dict({"walls": {"thickness": 0.1, "polylines": [back.tolist()]},
                                     "robot": {"start": [*start, 0.0]}}, where="moved.yaml"))
    c = classify_surface(est, segs, pose, 0.0).counts
    assert c["surface_precision"] == 1.0 and c["surface_sensitivity"] > 0.999
    assert classify_surface(est, segs, (0.0, 0.0, 0.0), 0.01).counts["surface_precision"] < 0.3
