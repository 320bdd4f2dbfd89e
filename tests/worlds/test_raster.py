"""Ground-truth rasterizer: hand-counted rooms, obstacles, unreachable space, and agreement
with what a perfect lidar hits."""
import numpy as np
import pytest
import shapely
from scipy import ndimage

from worlds.coverage import resample_path
from worlds.load import load_world, world_from_dict
from worlds.raster import MARGIN_CELLS, cell_centres, grid_frame, rasterize, true_walls
from worlds.visibility import beam_angles, cast_rays, hit_cells


def square_room(side=1.0, thickness=0.12, **extra):
    """A room whose wall centre lines run at -0.075 and side + 0.075: surfaces at -0.015 and
    side + 0.015, inside free size side + 0.03."""
    e = 0.075
    d = {"name": "square", "walls": {"thickness": thickness, "polylines": [
        [[-e, -e], [side + e, -e], [side + e, side + e], [-e, side + e], [-e, -e]]]},
         "robot": {"start": [side / 2, side / 2, 0.0]}}
    d.update(extra)
    return world_from_dict(d, where="square.yaml")


def test_single_square_room_by_hand():
    g = rasterize(square_room(1.0))
    # solid spans [-0.135, 1.135]: cells from floor(-2.7) - 3 = -6 to ceil(22.7) + 3 = 26
    assert g.resolution == 0.05
    np.testing.assert_array_equal(g.origin, [-0.3, -0.3, 0.0])
    assert g.shape == (32, 32)
    # free: centres 0.025 .. 0.975 -> 20 x 20 cells; occupied: the ring of 22 x 22 around them
    assert g.free().sum() == 400
    assert g.occupied().sum() == 22 * 22 - 400 == 84
    assert np.isnan(g.prob).sum() == 32 * 32 - 484
    xy = g.occupied_xy()
    on_x = np.isclose(xy[:, 0], -0.025) | np.isclose(xy[:, 0], 1.025)
    on_y = np.isclose(xy[:, 1], -0.025) | np.isclose(xy[:, 1], 1.025)
    assert np.all(on_x | on_y)
    assert xy[:, 0].min() == pytest.approx(-0.025) and xy[:, 0].max() == pytest.approx(1.025)
    # the four inside corners are occupied cells: corner beams end in them
    for cx, cy in [(-0.025, -0.025), (1.025, -0.025), (-0.025, 1.025), (1.025, 1.025)]:
        r, c = g.world_to_cell(np.array([[cx, cy]]))
        assert g.prob[r[0], c[0]] == 1.0
    free_xy = g.cell_to_world(*np.nonzero(g.free()))
    assert free_xy.min() == pytest.approx(0.025) and free_xy.max() == pytest.approx(0.975)


def test_square_room_coarser_resolution():
    g = rasterize(square_room(1.0), resolution=0.1)
    assert g.resolution == 0.1
    np.testing.assert_allclose(g.origin, [-0.5, -0.5, 0.0])
    assert g.free().sum() == 100 and g.occupied().sum() == 44


def test_rectangle_s_by_hand():
    g = rasterize(load_world("rectangle_s"))
    assert g.free().sum() == 60 * 40
    assert g.occupied().sum() == 62 * 42 - 60 * 40


def test_same_as_solid_centre_rule_on_shipped_worlds():
    """With surfaces 0.015 m past cell edges, occupied == solid-centred cells bordering free."""
    for name in ("rectangle_m", "swirl_m", "corridor", "loop"):
        w = load_world(name)
        g = rasterize(w)
        X, Y = cell_centres(g.origin[0], g.origin[1], g.resolution, g.rows, g.cols)
        solid = shapely.contains_xy(w.solid, X, Y)
        border = solid & ndimage.binary_dilation(g.free(), structure=np.ones((3, 3), bool))
        np.testing.assert_array_equal(g.occupied(), border, err_msg=name)


def test_margin_and_origin_snap():
    w = load_world("swirl_s")
    ox, oy, res, rows, cols = grid_frame(w)
    assert (ox / res) == pytest.approx(round(ox / res)) and (oy / res) == pytest.approx(round(oy / res))
    xmin, ymin, xmax, ymax = w.bounds
    assert ox <= xmin - MARGIN_CELLS * res + 1e-9 and ox + cols * res >= xmax + MARGIN_CELLS * res - 1e-9


def test_unreachable_room_is_unknown():
    # a closed inner box: its inside is free space of another room, not reachable
    w = square_room(2.0, walls={"thickness": 0.12, "polylines": [
        [[-0.075, -0.075], [2.075, -0.075], [2.075, 2.075], [-0.075, 2.075], [-0.075, -0.075]],
        [[1.225, 1.225], [1.825, 1.225], [1.825, 1.825], [1.225, 1.825], [1.225, 1.225]]]},
        robot={"start": [0.5, 0.5, 0.0]})
    g = rasterize(w)
    r, c = g.world_to_cell(np.array([[1.525, 1.525]]))
    assert np.isnan(g.prob[r[0], c[0]])
    # the inner box's inner surfaces are not seen; its outer surfaces are
    inner = (1.285, 1.765)  # inner free span of the box
    occ = g.occupied_xy()
    inside = (occ[:, 0] > inner[0] + 0.03) & (occ[:, 0] < inner[1] - 0.03) & \
             (occ[:, 1] > inner[0] + 0.03) & (occ[:, 1] < inner[1] - 0.03)
    assert not inside.any()
    outer_face = np.isclose(occ[:, 0], 1.175) & (occ[:, 1] > 1.3) & (occ[:, 1] < 1.7)
    assert outer_face.sum() == 8


def test_obstacle_surfaces_are_occupied_and_inside_unknown():
    w = load_world("tests/data/worlds_obstacles.yaml")
    g = rasterize(w)
    # the circle's centre is deep inside the solid: unknown; its rim: occupied
    r, c = g.world_to_cell(np.array([[2.9, 1.01]]))
    assert np.isnan(g.prob[r[0], c[0]])
    for ang in np.linspace(0, 2 * np.pi, 24, endpoint=False):
        p = np.array([[2.9 + 0.26 * np.cos(ang), 1.01 + 0.26 * np.sin(ang)]])
        r, c = g.world_to_cell(p)
        assert g.prob[r[0], c[0]] == 1.0
    # every occupied cell touches the solid, every free cell centre is outside it
    occ = g.occupied_xy()
    half = g.resolution / 2
    boxes = shapely.box(occ[:, 0] - half, occ[:, 1] - half, occ[:, 0] + half, occ[:, 1] + half)
    assert shapely.intersects(boxes, w.solid).all()
    free = g.cell_to_world(*np.nonzero(g.free()))
    assert not shapely.contains_xy(w.solid, free[:, 0], free[:, 1]).any()


def _lidar_hits(w, g, step=0.1, n_beams=720, max_range=3.5):
    pts = resample_path(np.vstack([w.start[:2], w.route]), step)
    angles = beam_angles(n_beams)
    ranges = cast_rays(w.segments, pts, angles, max_range)
    return hit_cells(g, pts, angles, ranges)


@pytest.mark.parametrize("name", ["rectangle_s", "rectangle_l", "swirl_s", "swirl_l", "corridor", "loop"])
def test_perfect_lidar_hits_land_on_occupied_cells(name):
    """Beams cast from the route end in occupied cells of the truth (>= 99%; 100% by design)."""
    w = load_world(name)
    g = rasterize(w)
    r, c = _lidar_hits(w, g, step=0.2)
    share = g.occupied()[r, c].mean()
    assert share >= 0.99
    assert share == 1.0


def test_perfect_lidar_hits_on_slanted_obstacles():
    w = load_world("tests/data/worlds_obstacles.yaml")
    g = rasterize(w)
    pts = np.array([[0.5, 0.5], [3.5, 0.5], [3.6, 2.0], [0.5, 2.5], [2.4, 1.8]])
    angles = beam_angles(1440)
    r, c = hit_cells(g, pts, angles, cast_rays(w.segments, pts, angles, 10.0))
    assert g.occupied()[r, c].mean() >= 0.999


@pytest.mark.parametrize("name", ["rectangle_s", "swirl_l", "corridor", "loop",
                                  "tests/data/worlds_obstacles.yaml"])
def test_true_walls_are_the_occupied_cells_of_the_truth(name):
    w = load_world(name)
    truth, walls = rasterize(w), true_walls(w)
    assert walls.shape == truth.shape and walls.resolution == truth.resolution
    np.testing.assert_array_equal(walls.origin, truth.origin)
    np.testing.assert_array_equal(walls.occupied(), truth.occupied())
    assert np.isnan(walls.prob[~walls.occupied()]).all()
