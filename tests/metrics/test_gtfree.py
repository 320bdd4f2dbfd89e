"""Ground-truth-free metrics (Filatov et al. 2017) on hand-drawn masks."""
import numpy as np

from metrics.gtfree import count_corners, count_enclosed_areas, gtfree_metrics
from worlds.grid import Grid


def outline(n, m, thick=1):
    a = np.zeros((n, m), bool)
    a[:thick, :] = a[-thick:, :] = True
    a[:, :thick] = a[:, -thick:] = True
    return a


def test_solid_block_has_four_corners():
    a = np.zeros((30, 30), bool)
    a[8:20, 5:25] = True
    assert count_corners(a) == 4


def test_hollow_room_has_eight_corners():
    a = np.zeros((40, 40), bool)
    a[5:35, 5:35] = outline(30, 30, thick=3)
    assert count_corners(a) == 8  # four outside, four inside


def test_noise_cells_add_corners():
    a = np.zeros((40, 40), bool)
    a[5:35, 5:35] = outline(30, 30, thick=3)
    clean = count_corners(a)
    a[15, 15] = a[22, 25] = a[28, 12] = True
    assert count_corners(a) > clean


def test_enclosed_areas():
    a = outline(20, 30)
    assert count_enclosed_areas(a) == 1
    a[:, 15] = True  # a dividing wall: two rooms
    assert count_enclosed_areas(a) == 2
    a[0, 5] = False  # a door in the outer wall opens the left room
    assert count_enclosed_areas(a) == 1
    assert count_enclosed_areas(np.zeros((5, 5), bool)) == 0


def test_diagonal_leak_is_closed_by_8_connected_walls():
    a = np.zeros((7, 7), bool)
    for i in range(7):  # a diagonal wall cuts the corner triangle off (4-connected open space)
        a[i, 6 - i] = True
    a[0, :] = a[:, 0] = False
    assert count_enclosed_areas(a) == 0  # both sides touch the border
    b = outline(10, 10)
    b[5, 5] = True
    assert count_enclosed_areas(b) == 1


def test_fractions():
    p = np.full((4, 5), np.nan)
    p[0, :] = 1.0
    p[1, :] = 0.0
    p[2, :2] = 0.5
    r = gtfree_metrics(Grid(p))
    assert r["occupied_fraction"] == 5 / 12 and r["free_fraction"] == 5 / 12
    assert gtfree_metrics(Grid(np.full((3, 3), np.nan)))["occupied_fraction"] == 0.0
