"""ROS map_server files: round trips, hand-made map_saver files, ASCII PGM, PNG, negate,
modes, errors."""
import warnings

import numpy as np
import pytest
import yaml
from PIL import Image

from worlds.grid import Grid
from worlds.mapio import encode_pgm, grid_to_pixels, read_map, read_pgm, write_map
from worlds.yamlio import InputError


def _trinary(rng, rows, cols):
    prob = rng.choice([0.0, 1.0, np.nan], size=(rows, cols), p=[0.5, 0.2, 0.3])
    return prob


@pytest.mark.parametrize("rows,cols,origin,res", [
    (1, 1, (0.0, 0.0, 0.0), 0.05),
    (7, 13, (-3.35, -0.15, 0.0), 0.05),      # non-square, odd, negative origin
    (40, 9, (12.5, -7.025, 0.0), 0.1),
    (33, 64, (-0.3, -0.30000000000000004, 0.25), 0.025),  # float noise and a yaw survive
])
def test_round_trip_identical(tmp_path, rng, rows, cols, origin, res):
    g = Grid(_trinary(rng, rows, cols), res, np.array(origin))
    write_map(g, tmp_path / "m.yaml")
    back = read_map(tmp_path / "m.yaml")
    assert back.equals(g)
    assert back.prob[0, 0] == g.prob[0, 0] or (np.isnan(back.prob[0, 0]) and np.isnan(g.prob[0, 0]))


def test_written_files_follow_map_saver(tmp_path):
    # grid row 0 is the bottom: it must be the last image row
    prob = np.array([[1.0, 0.0, np.nan],
                     [0.5, 0.1, 0.7]])
    write_map(Grid(prob, 0.05, np.array([-1.0, 2.0, 0.0])), tmp_path / "out" / "map.yaml")
    meta = yaml.safe_load((tmp_path / "out" / "map.yaml").read_text())
    assert meta["image"] == "map.pgm"
    assert meta["negate"] == 0
    assert meta["occupied_thresh"] == 0.65 and meta["free_thresh"] == 0.196
    assert meta["origin"] == [-1.0, 2.0, 0.0]
    data = (tmp_path / "out" / "map.pgm").read_bytes()
    assert data.startswith(b"P5\n")
    raster = data[-6:]
    # top image row = grid row 1: 0.5 -> unknown 205, 0.1 -> free 254, 0.7 -> occupied 0
    assert list(raster) == [205, 254, 0, 0, 254, 205]
    assert data[:-6].rstrip().endswith(b"3 2\n255")


def _write_pair(tmp_path, pixels_top_first, yaml_text, ascii_pgm=False, name="map"):
    h, w = np.asarray(pixels_top_first).shape
    if ascii_pgm:
        body = "\n".join(" ".join(str(int(v)) for v in row) for row in pixels_top_first)
        (tmp_path / f"{name}.pgm").write_text(f"P2\n# hand-made\n{w} {h}\n255\n{body}\n")
    else:
        (tmp_path / f"{name}.pgm").write_bytes(
            b"P5\n# CREATOR: map_saver.cpp 0.050 m/pix\n" + f"{w} {h}\n255\n".encode()
            + bytes(np.asarray(pixels_top_first, dtype=np.uint8).ravel()))
    (tmp_path / f"{name}.yaml").write_text(yaml_text.replace("image: map.pgm", f"image: {name}.pgm"))
    return tmp_path / f"{name}.yaml"


MAP_SAVER_YAML = """image: map.pgm
resolution: 0.050000
origin: [-10.000000, -5.500000, 0.000000]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196
"""


@pytest.fixture
def map_saver_pair(tmp_path):
    """A map as ROS 1 map_saver writes it, by hand: 4 wide, 3 high."""
    pixels = [[205, 205, 0, 0],      # top row (grid row 2)
              [254, 254, 254, 0],
              [0, 254, 205, 254]]    # bottom row (grid row 0)
    return _write_pair(tmp_path, pixels, MAP_SAVER_YAML)


def test_reads_a_map_saver_pair(map_saver_pair):
    g = read_map(map_saver_pair)
    assert g.shape == (3, 4)
    assert g.resolution == 0.05
    np.testing.assert_array_equal(g.origin, [-10.0, -5.5, 0.0])
    expect = np.array([[1.0, 0.0, np.nan, 0.0],
                       [0.0, 0.0, 0.0, 1.0],
                       [np.nan, np.nan, 1.0, 1.0]])
    np.testing.assert_array_equal(g.prob, expect)
    # world coordinates: cell (0, 0) spans [-10, -9.95) x [-5.5, -5.45)
    r, c = g.world_to_cell(np.array([[-9.97, -5.49], [-9.81, -5.36]]))
    assert list(r) == [0, 2] and list(c) == [0, 3]


def test_ascii_pgm_and_comments(tmp_path):
    p = _write_pair(tmp_path, [[0, 254], [205, 128]], MAP_SAVER_YAML, ascii_pgm=True)
    g = read_map(p)
    # 128: p = 0.498, between the thresholds -> unknown
    np.testing.assert_array_equal(g.prob, [[np.nan, np.nan], [1.0, 0.0]])


def test_negate(tmp_path):
    text = MAP_SAVER_YAML.replace("negate: 0", "negate: 1")
    g = read_map(_write_pair(tmp_path, [[255, 1, 50]], text))
    # negated: 255 -> 0 -> occupied; 1 -> 254 -> free; 50 -> 205 -> unknown
    np.testing.assert_array_equal(g.prob, [[1.0, 0.0, np.nan]])


def test_strict_thresholds(tmp_path):
    # p exactly at a threshold is neither: occupied needs p > 0.6, free p < 0.2
    text = MAP_SAVER_YAML.replace("0.65", "0.6").replace("0.196", "0.2")
    with pytest.warns(UserWarning, match="reads the unknown value 205 as free"):
        g = read_map(_write_pair(tmp_path, [[102, 204, 101, 205]], text))
    # 102 -> p = 0.6 (not > 0.6); 204 -> p = 0.2 (not < 0.2); 101 -> 0.604 occupied; 205 -> 0.196 free
    np.testing.assert_array_equal(g.prob, [[np.nan, np.nan, 1.0, 0.0]])


def test_scale_and_raw_modes(tmp_path):
    g = read_map(_write_pair(tmp_path, [[0, 254, 128]], MAP_SAVER_YAML + "mode: scale\n", name="s"))
    p = (255 - 128) / 255
    np.testing.assert_allclose(g.prob, [[1.0, 0.0, 0.99 * (p - 0.196) / (0.65 - 0.196)]])
    g = read_map(_write_pair(tmp_path, [[0, 100, 65, 255]],
                             MAP_SAVER_YAML + "mode: raw\n", name="r"))
    np.testing.assert_array_equal(g.prob, [[0.0, 1.0, 0.65, np.nan]])


def test_bad_mode_rejected(tmp_path):
    with pytest.raises(InputError, match=r"map\.yaml: mode: expected trinary, scale or raw"):
        read_map(_write_pair(tmp_path, [[0]], MAP_SAVER_YAML + "mode: fancy\n"))


def test_warns_when_free_thresh_reads_unknown_as_free(tmp_path):
    text = MAP_SAVER_YAML.replace("0.196", "0.25")
    p = _write_pair(tmp_path, [[205, 0]], text)
    with pytest.warns(UserWarning, match="free_thresh 0.25 reads the unknown value 205 as free"):
        g = read_map(p)
    np.testing.assert_array_equal(g.prob, [[0.0, 1.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_map(_write_pair(tmp_path, [[205]], MAP_SAVER_YAML, name="ok"))


def test_missing_pgm(tmp_path):
    (tmp_path / "m.yaml").write_text(MAP_SAVER_YAML)
    with pytest.raises(InputError, match=r"/map\.pgm: image file not found"):
        read_map(tmp_path / "m.yaml")


def test_size_mismatch(tmp_path):
    (tmp_path / "map.pgm").write_bytes(b"P5\n4 3\n255\n" + bytes(10))
    (tmp_path / "m.yaml").write_text(MAP_SAVER_YAML)
    with pytest.raises(InputError, match=r"map\.pgm: PGM raster truncated \(10 of 12 bytes\)"):
        read_map(tmp_path / "m.yaml")


def test_not_a_pgm(tmp_path):
    (tmp_path / "map.pgm").write_bytes(b"\x89PNG\r\n\x1a\n....")
    (tmp_path / "m.yaml").write_text(MAP_SAVER_YAML)
    with pytest.raises(InputError, match=r"map\.pgm: not a PGM image"):
        read_map(tmp_path / "m.yaml")


@pytest.mark.parametrize("field", ["image", "resolution", "origin", "occupied_thresh", "free_thresh"])
def test_missing_yaml_field(tmp_path, field):
    text = "\n".join(l for l in MAP_SAVER_YAML.splitlines() if not l.startswith(field))
    p = _write_pair(tmp_path, [[0]], text + "\n")
    with pytest.raises(InputError, match=rf"map\.yaml: {field}: missing required field"):
        read_map(p)


def test_bad_yaml_values(tmp_path):
    p = _write_pair(tmp_path, [[0]], MAP_SAVER_YAML.replace("0.050000", "fine"))
    with pytest.raises(InputError, match=r"map\.yaml: resolution: expected a number, got 'fine'"):
        read_map(p)
    p = _write_pair(tmp_path, [[0]], MAP_SAVER_YAML.replace("[-10.000000, -5.500000, 0.000000]", "[1]"),
                    name="o")
    with pytest.raises(InputError, match=r"o\.yaml: origin: expected \[x, y, yaw\]"):
        read_map(p)
    p = _write_pair(tmp_path, [[0]], MAP_SAVER_YAML.replace("occupied_thresh", "ocupied_thresh"), name="t")
    with pytest.raises(InputError, match=r"t\.yaml: ocupied_thresh: unknown key \(did you mean 'occupied_thresh'\?\)"):
        read_map(p)


def test_pgm_16_bit_and_maxval(tmp_path):
    (tmp_path / "a.pgm").write_bytes(b"P5 2 1 65535\n" + np.array([0, 65535], dtype=">u2").tobytes())
    np.testing.assert_array_equal(read_pgm(tmp_path / "a.pgm"), [[0.0, 255.0]])
    (tmp_path / "b.pgm").write_text("P2\n3 1\n15\n0 15 5\n")
    np.testing.assert_array_equal(read_pgm(tmp_path / "b.pgm"), [[0.0, 255.0, 85.0]])


def test_encode_pgm_header():
    data = encode_pgm(np.array([[1, 2, 3]], dtype=np.uint8))
    assert data == b"P5\n3 1\n255\n\x01\x02\x03"


def test_grid_to_pixels_thresholds():
    g = Grid(np.array([[0.196, 0.197, 0.649, 0.65, np.nan]]))
    assert list(grid_to_pixels(g)[0]) == [254, 205, 205, 0, 205]


# --- PNG ---------------------------------------------------------------------------------

def _write_png_pair(tmp_path, pixels, yaml_text, mode=None, name="p", **save):
    arr = np.asarray(pixels, dtype=np.uint8)
    img = Image.fromarray(arr)
    if mode and img.mode != mode:
        img = img.convert(mode)
    img.save(tmp_path / f"{name}.png", **save)
    (tmp_path / f"{name}.yaml").write_text(yaml_text.replace("image: map.pgm", f"image: {name}.png"))
    return tmp_path / f"{name}.yaml"


@pytest.mark.parametrize("rows,cols,origin,res", [(1, 1, (0.0, 0.0, 0.0), 0.05),
                                                  (7, 13, (-3.35, -0.15, 0.25), 0.05)])
def test_pgm_and_png_of_the_same_map_read_back_identically(tmp_path, rng, rows, cols, origin, res):
    g = Grid(_trinary(rng, rows, cols), res, np.array(origin))
    assert write_map(g, tmp_path / "a.yaml") == tmp_path / "a.pgm"
    assert write_map(g, tmp_path / "b.yaml", image_format="png") == tmp_path / "b.png"
    assert yaml.safe_load((tmp_path / "b.yaml").read_text())["image"] == "b.png"
    with Image.open(tmp_path / "b.png") as img:
        assert (img.format, img.mode, img.size) == ("PNG", "L", (cols, rows))
    a, b = read_map(tmp_path / "a.yaml"), read_map(tmp_path / "b.yaml")
    assert a.equals(g) and b.equals(g)
    np.testing.assert_array_equal(a.prob, b.prob)


@pytest.mark.parametrize("mode", ["L", "RGB", "RGBA", "P", "LA"])
def test_hand_made_png_reads_as_the_pgm(tmp_path, mode):
    pixels = [[205, 205, 0, 0], [254, 254, 254, 0], [0, 254, 128, 254]]
    # an opaque alpha counts in trinary mode (test_scale_mode_png_as_nav2_writes_it)
    yaml_text = MAP_SAVER_YAML + ("mode: scale\n" if mode in ("RGBA", "LA") else "")
    png = read_map(_write_png_pair(tmp_path, pixels, yaml_text, mode))
    pgm = read_map(_write_pair(tmp_path, pixels, yaml_text))
    np.testing.assert_array_equal(png.prob, pgm.prob)
    np.testing.assert_array_equal(png.origin, [-10.0, -5.5, 0.0])


def test_png_negate_and_raw(tmp_path):
    text = MAP_SAVER_YAML.replace("negate: 0", "negate: 1")
    g = read_map(_write_png_pair(tmp_path, [[255, 1, 50]], text))
    np.testing.assert_array_equal(g.prob, [[1.0, 0.0, np.nan]])
    g = read_map(_write_png_pair(tmp_path, [[0, 100, 65, 255]], MAP_SAVER_YAML + "mode: raw\n",
                                 name="r"))
    np.testing.assert_array_equal(g.prob, [[0.0, 1.0, 0.65, np.nan]])


def test_scale_mode_png_as_nav2_writes_it(tmp_path):
    # Nav2 map_saver in scale mode: RGBA, grey (100 - occupancy) / 100, unknown transparent
    grey = np.array([[0, 254, 128, 0]], dtype=np.uint8)
    alpha = np.array([[255, 255, 255, 0]], dtype=np.uint8)
    rgba = np.stack([grey, grey, grey, alpha], axis=-1)
    Image.fromarray(rgba, "RGBA").save(tmp_path / "s.png")
    (tmp_path / "s.yaml").write_text(MAP_SAVER_YAML.replace("map.pgm", "s.png") + "mode: scale\n")
    g = read_map(tmp_path / "s.yaml")
    p = (255 - 128) / 255
    np.testing.assert_allclose(g.prob, [[1.0, 0.0, 0.99 * (p - 0.196) / (0.65 - 0.196), np.nan]])
    # trinary mode averages the alpha in, as map_server does: opaque 205 reads (3*205+255)/4
    (tmp_path / "t.yaml").write_text(MAP_SAVER_YAML.replace("map.pgm", "s.png"))
    np.testing.assert_array_equal(read_map(tmp_path / "t.yaml").prob, [[1.0, 0.0, np.nan, 1.0]])


def test_broken_png(tmp_path):
    Image.fromarray(np.zeros((40, 40), dtype=np.uint8)).save(tmp_path / "map.png")
    data = (tmp_path / "map.png").read_bytes()
    (tmp_path / "map.png").write_bytes(data[:-30])
    (tmp_path / "m.yaml").write_text(MAP_SAVER_YAML.replace("map.pgm", "map.png"))
    with pytest.raises(InputError, match=r"/map\.png: broken PNG image") as err:
        read_map(tmp_path / "m.yaml")
    assert "\n" not in str(err.value)


def test_non_image_named_png(tmp_path):
    (tmp_path / "map.png").write_text("resolution: 0.05\n")
    (tmp_path / "m.yaml").write_text(MAP_SAVER_YAML.replace("map.pgm", "map.png"))
    with pytest.raises(InputError, match=r"/map\.png: not an image \(Pillow cannot identify it\)"):
        read_map(tmp_path / "m.yaml")
    (tmp_path / "map.png").write_bytes(encode_pgm(np.zeros((2, 2))))
    with pytest.raises(InputError, match=r"/map\.png: not a PNG image \(Pillow reads it as PPM\)"):
        read_map(tmp_path / "m.yaml")


def test_missing_png(tmp_path):
    (tmp_path / "m.yaml").write_text(MAP_SAVER_YAML.replace("map.pgm", "map.png"))
    with pytest.raises(InputError, match=r"/map\.png: image file not found"):
        read_map(tmp_path / "m.yaml")


def test_16_bit_png_refused(tmp_path):
    Image.fromarray(np.array([[0, 65535]], dtype=np.uint16)).save(tmp_path / "map.png")
    (tmp_path / "m.yaml").write_text(MAP_SAVER_YAML.replace("map.pgm", "map.png"))
    with pytest.raises(InputError, match=r"/map\.png: unsupported PNG pixel mode I;16"):
        read_map(tmp_path / "m.yaml")


def test_png_size_checked_before_decoding(tmp_path, monkeypatch):
    Image.fromarray(np.zeros((30, 40), dtype=np.uint8)).save(tmp_path / "map.png")
    (tmp_path / "m.yaml").write_text(MAP_SAVER_YAML.replace("map.pgm", "map.png"))
    monkeypatch.setenv("SLAM_BENCH_MAX_CELLS", "1000")
    monkeypatch.setattr(Image.Image, "load", lambda self: pytest.fail("decoded before the check"))
    with pytest.raises(InputError, match=r"/map\.png: a 40 x 30 image needs a grid of 30 x 40 cells"):
        read_map(tmp_path / "m.yaml")


def test_write_map_bad_image_format(tmp_path):
    with pytest.raises(InputError, match="expected pgm or png, got 'jpg'"):
        write_map(Grid(np.zeros((2, 2))), tmp_path / "m.yaml", image_format="jpg")
