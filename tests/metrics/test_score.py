"""score_map on hand-built maps with answers known by hand (the issue's "done when" list)."""
import numpy as np
import pytest

from metrics.score import classify, save_overlay_png, score_map
from metrics.truth import prepare_truth
from slam.pose import compose, inverse
from tests.metrics.maps import ROOM, draw
from worlds.grid import Grid
from worlds.yamlio import InputError

RES = 0.05


@pytest.fixture(scope="module")
def truth():
    return draw(ROOM)


def yaw_err_deg(a, b):
    return abs(np.rad2deg(np.angle(np.exp(1j * (a - b)))))


@pytest.mark.parametrize("mode, initial", [("auto", (0, 0, 0)), ("icp", (0, 0, 0)),
                                           ("global", None), ("none", (0, 0, 0)),
                                           ("start", (0, 0, 0))])
def test_identical_maps(truth, mode, initial):
    r = score_map(truth, truth, align=mode, initial=initial)
    assert r["precision"] == 1.0 and r["sensitivity"] == 1.0 and r["f1"] == 1.0
    assert r["fp"] == 0 and r["fn"] == 0 and r["tp"] == int(truth.occupied().sum())
    assert r["adnn_m"] == pytest.approx(0.0, abs=1e-9) and r["adnn_cells"] == pytest.approx(0.0, abs=1e-9)
    assert r["adnn_reverse_cells"] == pytest.approx(0.0, abs=1e-9)
    assert r["ssim"] == pytest.approx(1.0)
    assert set(r["align"]) == {"x", "y", "yaw"}


def test_half_the_walls_missing(truth):
    prob = truth.prob.copy()
    half = truth.cols // 2
    prob[:, half:][prob[:, half:] >= 0.65] = 0.0  # the right half of every wall is gone
    est = truth.with_prob(prob)
    kept = int(est.occupied().sum())
    total = int(truth.occupied().sum())
    r = score_map(est, truth)
    assert r["precision"] == 1.0
    assert r["sensitivity"] == pytest.approx(kept / total)
    assert 0.4 < r["sensitivity"] < 0.6
    assert r["adnn_m"] == pytest.approx(0.0, abs=1e-9)  # ADNN does not see what is missing
    assert r["adnn_reverse_m"] > 0.5                     # the reverse direction does
    assert np.hypot(r["align"]["x"], r["align"]["y"]) < 1e-6


def shifted_rotated():
    """3 cells right and 10 degrees about the room centre."""
    centre = np.array([3.0, 2.5, 0.0])
    return compose(compose(centre + [3 * RES, 0, 0], [0, 0, np.deg2rad(10)]), inverse(centre))


def test_shift_rotate_same_cells(truth):
    """The same cell array under a moved origin: realigned, it scores as the unshifted map."""
    move = shifted_rotated()
    # the estimate's frame is `move` in the truth's world: a truth point p sits at move^-1 (+) p
    est = Grid(truth.prob, RES, compose(inverse(move), truth.origin))
    for mode, initial in [("icp", (0.0, 0.0, 0.0)), ("global", None)]:
        r = score_map(est, truth, align=mode, initial=initial)
        a = np.array([r["align"]["x"], r["align"]["y"], r["align"]["yaw"]])
        assert yaw_err_deg(a[2], move[2]) < 0.5, mode
        assert np.hypot(*(a[:2] - move[:2])) < 0.5 * RES, mode
        assert (r["precision"], r["sensitivity"], r["fp"], r["fn"]) == (1.0, 1.0, 0, 0), mode
        assert r["adnn_cells"] == pytest.approx(0.0, abs=1e-6)


def test_shift_rotate_rasterized_afresh(truth):
    """The walls drawn anew in the moved frame: realigned within half a cell and 0.5 degree;
    the staircase of the rotated walls differs from the truth by at most one cell."""
    move = shifted_rotated()
    est = draw(ROOM, pose=move)
    for mode, initial in [("icp", (0.0, 0.0, 0.0)), ("global", None)]:
        r = score_map(est, truth, align=mode, initial=initial, tolerance=1)
        a = np.array([r["align"]["x"], r["align"]["y"], r["align"]["yaw"]])
        assert yaw_err_deg(a[2], move[2]) < 0.5, mode
        assert np.hypot(*(a[:2] - move[:2])) < 0.5 * RES, mode
        assert r["precision"] == 1.0 and r["sensitivity"] == 1.0, mode
        assert r["adnn_cells"] < 0.5


def test_scattered_noise_exact_precision(truth, rng):
    free = truth.free()
    near_wall = np.zeros_like(free)
    r_, c_ = np.nonzero(truth.occupied())
    for dr in range(-4, 5):
        for dc in range(-4, 5):
            near_wall[np.clip(r_ + dr, 0, truth.rows - 1), np.clip(c_ + dc, 0, truth.cols - 1)] = True
    cand = np.argwhere(free & ~near_wall)
    noise = cand[rng.choice(len(cand), 40, replace=False)]
    prob = truth.prob.copy()
    prob[noise[:, 0], noise[:, 1]] = 1.0
    r = score_map(truth.with_prob(prob), truth)
    n_true = int(truth.occupied().sum())
    assert (r["tp"], r["fp"], r["fn"]) == (n_true, 40, 0)
    assert r["precision"] == n_true / (n_true + 40)
    assert r["sensitivity"] == 1.0
    assert r["corners"] > score_map(truth, truth)["corners"]


def test_empty_estimate_is_defined(truth):
    est = truth.with_prob(np.where(truth.occupied(), 0.0, truth.prob))
    r = score_map(est, truth)
    assert r["precision"] == 0.0 and r["sensitivity"] == 0.0 and r["f1"] == 0.0
    assert r["tp"] == 0 and r["fn"] == int(truth.occupied().sum())
    assert np.isnan(r["adnn_m"]) and "no occupied cell" in r["note"]


def test_empty_truth_is_an_input_error(truth):
    with pytest.raises(InputError, match="true map has no occupied cell"):
        score_map(truth, Grid(np.zeros((10, 10))))


@pytest.mark.parametrize("resolution", [0.025, 0.1])
def test_other_resolution_is_resampled(truth, resolution):
    est = draw(ROOM, resolution=resolution)
    r = score_map(est, truth, tolerance=1)
    assert r["precision"] > 0.97 and r["sensitivity"] > 0.97
    assert np.hypot(r["align"]["x"], r["align"]["y"]) < 0.5 * RES
    assert abs(r["align"]["yaw"]) < np.deg2rad(0.5)


def test_prepared_truth_gives_the_same_answer(truth):
    est = draw(ROOM, pose=(0.05, -0.05, 0.02))
    a = score_map(est, truth)
    b = score_map(est, prepare_truth(truth))
    assert a == b


def test_estimate_beyond_the_truth_counts_as_false_positive(truth):
    # a wall 1 m outside the true map's grid must be an FP, not cropped away
    prob = np.pad(truth.prob, ((0, 0), (0, 40)), constant_values=np.nan)
    prob[30:60, truth.cols + 30] = 1.0
    est = Grid(prob, RES, truth.origin)
    r = score_map(est, truth, align="none")
    assert r["fp"] == 30 and r["fn"] == 0


def test_overlay_masks_and_png(truth, tmp_path):
    prob = truth.prob.copy()
    prob[prob >= 0.65] = np.where(np.arange(int((prob >= 0.65).sum())) % 2 == 0, 1.0, 0.0)
    prob[50, 60] = 1.0  # (2.5 m, 2.0 m): open floor
    est = truth.with_prob(prob)
    ov = classify(est, truth, {"x": 0.0, "y": 0.0, "yaw": 0.0})
    c = ov.classes.counts
    assert c["fp"] == 1 and c["tp"] + c["fn"] == int(truth.occupied().sum())
    from metrics.plot import COLOURS, overlay_rgb
    rgb = overlay_rgb(ov)
    assert tuple(rgb[ov.classes.fp][0]) == COLOURS["fp"]
    assert tuple(rgb[ov.classes.fn][0]) == COLOURS["fn"]
    assert tuple(rgb[ov.classes.tp][0]) == COLOURS["tp"]
    out = tmp_path / "sub" / "overlay.png"
    save_overlay_png(est, truth, np.zeros(3), out, title="half the cells")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 5000


def shipped_worlds():
    try:
        from worlds import list_worlds
        return list_worlds()
    except ImportError:  # worlds package not built yet
        return []


@pytest.mark.parametrize("name", shipped_worlds())
def test_global_on_shipped_world_truths(name):
    """A random rigid transform of a shipped world's true map: `global` finds an alignment
    under which it scores perfectly; for worlds without a symmetry, the transform itself."""
    from worlds import load_world, rasterize

    truth = rasterize(load_world(name))
    rng = np.random.default_rng(sum(map(ord, name)))
    move = np.array([*rng.uniform(-2.0, 2.0, 2), rng.uniform(-np.pi, np.pi)])
    est = Grid(truth.prob, truth.resolution, compose(inverse(move), truth.origin))
    r = score_map(est, truth, initial=None)
    assert r["align_mode"] == "global"
    assert (r["precision"], r["sensitivity"], r["fp"], r["fn"]) == (1.0, 1.0, 0, 0)
    if name.startswith("swirl"):  # no rotational symmetry
        a = np.array([r["align"]["x"], r["align"]["y"], r["align"]["yaw"]])
        assert yaw_err_deg(a[2], move[2]) < 0.5
        assert np.hypot(*(a[:2] - move[:2])) < 0.5 * truth.resolution


def test_coarser_estimate_of_a_shipped_world():
    from worlds import load_world, rasterize

    if "swirl_m" not in shipped_worlds():
        pytest.skip("swirl_m not shipped")
    world = load_world("swirl_m")
    truth = rasterize(world)
    r = score_map(rasterize(world, resolution=0.1), truth, tolerance=1)
    assert r["precision"] > 0.95 and r["sensitivity"] > 0.95


def test_surface_form_under_the_alignment_refined_onto_the_surfaces():
    """With the world's surfaces, score_map reports the surface form at the default tau under
    the cell form's alignment refined onto the surfaces (surface_align); without them, none
    of its keys."""
    from metrics.surface import DEFAULT_TAU_M, classify_surface, visible_surfaces
    from worlds.load import world_from_dict
    from worlds.raster import rasterize
    world = world_from_dict({"walls": {"thickness": 0.1, "polylines": [
        [[0, 0], [3.0, 0], [3.0, 2.0], [0, 2.0], [0, 0]]]},
        "obstacles": [{"box": {"center": [2.0, 1.0], "size": [0.4, 0.3], "yaw": 0.5}}],
        "robot": {"start": [0.6, 0.6, 0.0]}}, where="room.yaml")
    truth, segs = rasterize(world), visible_surfaces(world)
    move = np.array([0.15, 0.1, np.deg2rad(2.0)])            # the map's frame in the world
    est = Grid(truth.prob, truth.resolution, compose(inverse(move), truth.origin))
    r = score_map(est, truth, surfaces=segs)
    al = np.array([r["surface_align"][k] for k in ("x", "y", "yaw")])
    expect = classify_surface(est, segs, al, DEFAULT_TAU_M).counts
    assert {k: r[k] for k in expect} == expect
    # the truth moved rigidly: both alignments recover the move to well within a cell
    for key in ("align", "surface_align"):
        got = np.array([r[key][k] for k in ("x", "y", "yaw")])
        assert np.abs(got[:2] - move[:2]).max() < 0.01 and abs(got[2] - move[2]) < 0.002, key
    assert r["surface_tau_m"] == DEFAULT_TAU_M
    assert r["surface_precision"] == 1.0 and r["surface_sensitivity"] == pytest.approx(1.0)
    # unaligned, the moved map scores far lower: the alignment was applied
    assert classify_surface(est, segs, (0, 0, 0), DEFAULT_TAU_M).portion.surface_precision < 0.2
    assert score_map(est, truth, surfaces=segs, tau_m=0.0)["surface_tau_m"] == 0.0
    assert not any(k.startswith("surface_") for k in score_map(est, truth))
