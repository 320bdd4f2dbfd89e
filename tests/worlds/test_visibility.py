"""Exact ray casting (numpy) against an independent shapely reference."""
import numpy as np
import pytest
import shapely

from worlds.grid import Grid
from worlds.load import load_world
from worlds.visibility import beam_angles, cast_rays, hit_cells, seen_mask


def _reference(segments, origin, angle, max_range):
    """Nearest intersection of the beam's LineString with any segment (shapely)."""
    end = origin + max_range * np.array([np.cos(angle), np.sin(angle)])
    beam = shapely.LineString([origin, end])
    best = np.inf
    for s in segments:
        hit = beam.intersection(shapely.LineString([s[:2], s[2:]]))
        if hit.is_empty:
            continue
        pts = np.asarray(shapely.get_coordinates(hit))
        best = min(best, float(np.min(np.hypot(*(pts - origin).T))))
    return best


@pytest.mark.parametrize("seed", range(5))
def test_cast_rays_matches_shapely(seed):
    rng = np.random.default_rng(seed)
    segs = rng.uniform(-3, 3, size=(12, 4))
    origins = rng.uniform(-2, 2, size=(4, 2))
    angles = rng.uniform(-np.pi, np.pi, size=25)
    got = cast_rays(segs, origins, angles, 4.0, chunk=500)  # small chunks exercise the loop
    for p in range(len(origins)):
        for b in range(len(angles)):
            ref = _reference(segs, origins[p], angles[b], 4.0)
            if np.isinf(ref):
                assert np.isinf(got[p, b])
            else:
                assert got[p, b] == pytest.approx(ref, abs=1e-9)


def test_cast_rays_in_a_known_room():
    w = load_world("rectangle_s")          # inside surfaces at x = -0.015, 3.015; y = -0.015, 2.015
    r = cast_rays(w.segments, np.array([[1.0, 1.0]]), np.array([0.0, np.pi / 2, np.pi, -np.pi / 2]), 5.0)
    np.testing.assert_allclose(r[0], [2.015, 1.015, 1.015, 1.015])
    r = cast_rays(w.segments, np.array([[1.0, 1.0]]), np.array([0.0]), 2.0)
    assert np.isinf(r[0, 0])


def test_hit_cells_and_seen_mask():
    g = Grid(np.zeros((10, 10)), 0.1, np.array([0.0, 0.0, 0.0]))
    segs = np.array([[0.55, 0.0, 0.55, 1.0]])   # a wall at x = 0.55, in column 5
    origins = np.array([[0.2, 0.45]])
    angles = np.array([0.0, np.pi])
    ranges = cast_rays(segs, origins, angles, 1.0)
    r, c = hit_cells(g, origins, angles, ranges)
    assert list(r) == [4] and list(c) == [5]
    m = seen_mask(g, segs, origins, 1.0, n_beams=360)
    assert m[:, 5].sum() >= 8 and m.sum() == m[:, 5].sum()


def test_beam_angles():
    a = beam_angles(4)
    np.testing.assert_allclose(a, [-np.pi, -np.pi / 2, 0.0, np.pi / 2])
