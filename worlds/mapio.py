"""ROS map_server map files: a YAML description beside a PGM or PNG image.

Reading follows map_server's image loader (ROS 1 `map_server`, ROS 2 `nav2_map_server`):
  - a pixel's value v (0..255; P2/P5 with another maxval are scaled to 0..255; a PNG's
    colour channels averaged, worlds.pngio);
  - a PNG with alpha: in `mode: trinary` the alpha is averaged in, v = (R + G + B + A) / 4,
    in `mode: scale` a pixel that is not opaque is unknown (Nav2 map_saver's scale PNGs);
  - `negate: 1` replaces v by 255 - v;
  - p = (255 - v) / 255, the probability that the cell is occupied;
  - `mode: trinary` (the default): occupied if p > occupied_thresh, free if p < free_thresh
    (strict comparisons), unknown otherwise -> Grid prob 1.0 / 0.0 / NaN;
  - `mode: scale`: as trinary at both ends, in between p is mapped linearly to
    0.99 * (p - free_thresh) / (occupied_thresh - free_thresh) (map_server's 0..99 scale);
  - `mode: raw`: v (rounded) itself is the occupancy in percent (0..100); other values are
    unknown.
The image is a PNG when its name ends in .png, else a PGM. The bottom image row is grid
row 0 (images are stored top row first).

Writing follows map_saver: 254 where p <= free_thresh (free), 0 where p >= occupied_thresh
(occupied), 205 everywhere else including unknown, thresholds 0.65 / 0.196, `negate: 0`,
`mode: trinary`, a binary P5 PGM (or an 8-bit grey PNG) named NAME.pgm (NAME.png) beside
NAME.yaml and referenced relatively. A trinary grid (values 1.0, 0.0, NaN) written and read
back is identical.
"""
from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import numpy as np
import yaml

from worlds.grid import Grid
from worlds.limits import MAX_RESOLUTION, check_coordinates, check_grid_cells
from worlds.yamlio import InputError, atomic_write_bytes, atomic_write_text, load_yaml, short

__all__ = ["read_map", "write_map", "read_pgm", "encode_pgm", "grid_to_pixels",
           "SAVE_OCCUPIED_THRESH", "SAVE_FREE_THRESH", "PIXEL_FREE", "PIXEL_OCCUPIED",
           "PIXEL_UNKNOWN"]

# map_saver's conventions (ROS 1 map_saver, Nav2 map_saver defaults)
SAVE_OCCUPIED_THRESH = 0.65
SAVE_FREE_THRESH = 0.196
PIXEL_FREE = 254
PIXEL_OCCUPIED = 0
PIXEL_UNKNOWN = 205

_KNOWN_KEYS = ["image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"]


# --- PGM ---------------------------------------------------------------------------------

def _pgm_tokens(data: bytes, count: int, where: str) -> tuple[list[int], int]:
    """The first `count` whitespace-separated integers after the magic, skipping # comments.

    Returns the integers and the offset just past the last one.
    """
    out: list[int] = []
    pos = 2
    n = len(data)
    while len(out) < count:
        while pos < n and data[pos:pos + 1].isspace():
            pos += 1
        if pos < n and data[pos:pos + 1] == b"#":
            while pos < n and data[pos:pos + 1] not in (b"\n", b"\r"):
                pos += 1
            continue
        m = re.match(rb"\d+", data[pos:pos + 20])
        if m is None:
            raise InputError(f"{where}: not a valid PGM header")
        out.append(int(m.group()))
        pos += m.end()
    return out, pos


def read_pgm(path: str | os.PathLike) -> np.ndarray:
    """Read a binary (P5) or ASCII (P2) PGM image.

    Returns (height, width) float64 pixel values scaled to 0..255, top image row first.
    Raises InputError naming the file if it is missing or not a PGM.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{p}: image file not found") from None
    except OSError as err:
        raise InputError(f"{p}: cannot read image: {err.strerror}") from None
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise InputError(f"{p}: not a PGM image (expected magic P5 or P2, got {magic!r}); "
                         "map images are PGM or PNG (named .png)")
    (width, height, maxval), pos = _pgm_tokens(data, 3, str(p))
    if width <= 0 or height <= 0 or not (0 < maxval < 65536):
        raise InputError(f"{p}: bad PGM header (width {width}, height {height}, maxval {maxval})")
    check_grid_cells(height, width, str(p), f"a {width} x {height} image")
    if magic == b"P5":
        pos += 1  # exactly one whitespace byte separates the header from the raster
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype("u1")
        nbytes = width * height * dtype.itemsize
        raster = data[pos:pos + nbytes]
        if len(raster) < nbytes:
            raise InputError(f"{p}: PGM raster truncated ({len(raster)} of {nbytes} bytes)")
        pix = np.frombuffer(raster, dtype=dtype).astype(np.float64)
    else:
        body = re.sub(rb"#[^\n\r]*", b" ", data[pos:])
        try:
            vals = [int(t) for t in body.split()]
        except ValueError:
            raise InputError(f"{p}: ASCII PGM raster holds a non-integer value") from None
        if len(vals) < width * height:
            raise InputError(f"{p}: PGM raster truncated ({len(vals)} of {width * height} values)")
        pix = np.asarray(vals[:width * height], dtype=np.float64)
    if np.any(pix > maxval):
        raise InputError(f"{p}: PGM pixel values exceed maxval {maxval}")
    if maxval != 255:
        pix = np.round(pix * (255.0 / maxval))
    return pix.reshape(height, width)


def encode_pgm(pixels: np.ndarray, comment: str = "") -> bytes:
    """Binary P5 PGM bytes of (height, width) uint8 pixels, top image row first."""
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    h, w = pixels.shape
    head = "P5\n"
    if comment:
        head += f"# {comment}\n"
    head += f"{w} {h}\n255\n"
    return head.encode("ascii") + pixels.tobytes()


# --- YAML + image -> Grid ----------------------------------------------------------------

def _number(meta: dict, key: str, where: str) -> float:
    """meta[key] as a finite float; InputError naming the file and the field otherwise."""
    v = meta[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise InputError(f"{where}: {key}: expected a number, got {v!r}")
    return float(v)


def read_map(yaml_path: str | os.PathLike) -> Grid:
    """Read a map_server YAML + image pair into a Grid.

    Returns a Grid with prob 1.0 occupied, 0.0 free, NaN unknown (trinary; see the module
    docstring for scale and raw), origin = the YAML's [x, y, yaw]. Warns if the file's
    free_thresh would read map_saver's unknown value 205 as free.
    """
    where = str(yaml_path)
    meta = load_yaml(yaml_path)
    if not isinstance(meta, dict):
        raise InputError(f"{where}: expected a mapping with image, resolution, origin, ...")
    for key in meta:
        if key not in _KNOWN_KEYS:
            # map_server ignores extra keys; so do we, but a likely typo deserves a word
            import difflib
            close = difflib.get_close_matches(str(key), _KNOWN_KEYS, n=1)
            if close and close[0] not in meta:
                raise InputError(f"{where}: {key}: unknown key (did you mean '{close[0]}'?)")
    for key in ("image", "resolution", "origin", "occupied_thresh", "free_thresh"):
        if key not in meta:
            raise InputError(f"{where}: {key}: missing required field")
    if not isinstance(meta["image"], str) or not meta["image"]:
        raise InputError(f"{where}: image: expected a file name, got {short(meta['image'])}")
    res = _number(meta, "resolution", where)
    if not 0 < res <= MAX_RESOLUTION:
        raise InputError(f"{where}: resolution: expected a cell size above 0 and at most "
                         f"{MAX_RESOLUTION:g} m, got {res}")
    origin = meta["origin"]
    if (not isinstance(origin, (list, tuple)) or len(origin) not in (2, 3)
            or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in origin)):
        raise InputError(f"{where}: origin: expected [x, y, yaw], got {short(origin)}")
    if not np.all(np.isfinite(origin)):
        raise InputError(f"{where}: origin: expected finite numbers, got {short(origin)}")
    check_coordinates(origin[:2], where, "origin")
    origin = [float(v) for v in origin] + ([0.0] if len(origin) == 2 else [])
    occ_th = _number(meta, "occupied_thresh", where)
    free_th = _number(meta, "free_thresh", where)
    if not (0.0 <= free_th <= occ_th <= 1.0):
        raise InputError(f"{where}: free_thresh {free_th} and occupied_thresh {occ_th}: "
                         "expected 0 <= free_thresh <= occupied_thresh <= 1")
    negate = meta.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise InputError(f"{where}: negate: expected 0 or 1, got {short(negate)}")
    mode = meta.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise InputError(f"{where}: mode: expected trinary, scale or raw, got {short(mode)}")

    image = Path(meta["image"])
    if not image.is_absolute():
        image = Path(yaml_path).parent / image
    alpha = None
    if image.suffix.lower() == ".png":
        from worlds.pngio import read_png
        pix, alpha = read_png(image)
        if alpha is not None and mode == "trinary":
            pix = (3.0 * pix + alpha) / 4.0
    else:
        pix = read_pgm(image)
    if negate:
        pix = 255.0 - pix
    prob = np.full(pix.shape, np.nan)
    if mode == "raw":
        pix = np.rint(pix)
        ok = pix <= 100
        prob[ok] = pix[ok] / 100.0
    else:
        p = (255.0 - pix) / 255.0
        occ = p > occ_th
        free = p < free_th
        prob[occ] = 1.0
        prob[free] = 0.0
        if mode == "scale" and occ_th > free_th:
            mid = ~occ & ~free
            prob[mid] = 0.99 * (p[mid] - free_th) / (occ_th - free_th)
        if mode == "scale" and alpha is not None:
            prob[alpha < 255] = np.nan
        if (255.0 - PIXEL_UNKNOWN) / 255.0 < free_th:
            warnings.warn(f"{where}: free_thresh {free_th} reads the unknown value {PIXEL_UNKNOWN} "
                          f"as free (map_saver's unknown is p = {50 / 255:.4f}); "
                          "unknown cells of this map will count as free", stacklevel=2)
    check_coordinates(np.asarray(origin[:2]) + res * np.array(pix.shape[::-1]), where,
                      "origin + image size x resolution (the map's far corner)")
    # image rows run top to bottom; grid row 0 is the bottom row
    return Grid(prob[::-1].copy(), res, np.asarray(origin))


# --- Grid -> YAML + image ----------------------------------------------------------------

def grid_to_pixels(grid: Grid, occupied_thresh: float = SAVE_OCCUPIED_THRESH,
                   free_thresh: float = SAVE_FREE_THRESH) -> np.ndarray:
    """(rows, cols) grid -> (rows, cols) uint8 map_saver pixels, top image row first."""
    prob = grid.prob
    pix = np.full(prob.shape, PIXEL_UNKNOWN, dtype=np.uint8)
    with np.errstate(invalid="ignore"):
        pix[prob <= free_thresh] = PIXEL_FREE
        pix[prob >= occupied_thresh] = PIXEL_OCCUPIED
    return pix[::-1].copy()


def write_map(grid: Grid, yaml_path: str | os.PathLike, image_format: str = "pgm") -> Path:
    """Write `grid` as a map_saver pair: YAML at yaml_path and the image beside it (same stem).

    image_format: "pgm" (binary P5, as ROS 1 map_saver) or "png" (8-bit grey, which Nav2
    reads too). Cells with p >= 0.65 are written occupied (0), p <= 0.196 free (254), the
    rest and NaN unknown (205). Both files are written atomically; returns the image path.
    """
    yp = Path(yaml_path)
    if yp.suffix.lower() not in (".yaml", ".yml"):
        raise InputError(f"{yp}: a map description must end in .yaml")
    if image_format not in ("pgm", "png"):
        raise InputError(f"image format: expected pgm or png, got {image_format!r}")
    image = yp.with_suffix(f".{image_format}")
    pix = grid_to_pixels(grid)
    if image_format == "png":
        from worlds.pngio import encode_png
        data = encode_png(pix)
    else:
        data = encode_pgm(pix, comment=f"{grid.cols} x {grid.rows} map, "
                                       f"resolution {grid.resolution} m")
    atomic_write_bytes(image, data)
    meta = {
        "image": image.name,
        "mode": "trinary",
        "resolution": float(grid.resolution),
        "origin": [float(v) for v in grid.origin],
        "negate": 0,
        "occupied_thresh": SAVE_OCCUPIED_THRESH,
        "free_thresh": SAVE_FREE_THRESH,
    }
    atomic_write_text(yp, yaml.safe_dump(meta, sort_keys=False, default_flow_style=None))
    return image
