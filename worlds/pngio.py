"""PNG map images through Pillow, read as map_server's image loader reads them (Nav2 map_io).

A pixel's value is the mean of its colour channels (a grey or palette image: its grey level),
0..255; the alpha channel, when the image has one, is returned apart, because map_server uses
it by mode (worlds.mapio). 16-bit and other modes are refused: map_saver writes 8-bit images.
"""
from __future__ import annotations

import io
import os
import warnings
from pathlib import Path

import numpy as np

from worlds.limits import check_grid_cells
from worlds.yamlio import InputError

__all__ = ["read_png", "encode_png"]

# Pillow modes read, and what each is converted to first
_CONVERT = {"1": "L", "L": "L", "LA": "LA", "RGB": "RGB", "RGBA": "RGBA", "PA": "RGBA", "P": None}


def read_png(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray | None]:
    """Read an 8-bit PNG map image (grey, grey + alpha, palette, RGB or RGBA).

    Returns (values, alpha): (height, width) float64 channel means 0..255 and the alpha
    channel 0..255 (255 opaque) or None, top image row first. The size is checked against
    worlds.limits before the pixels are decoded. InputError naming the file if it is
    missing, not an image, not a PNG, broken or of an unsupported mode.
    """
    from PIL import Image, UnidentifiedImageError
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: image file not found")
    try:
        with warnings.catch_warnings():
            # the cell limit below is the bound that counts here
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(p) as img:
                if img.format != "PNG":
                    raise InputError(f"{p}: not a PNG image (Pillow reads it as {img.format})")
                width, height = img.size
                check_grid_cells(height, width, str(p), f"a {width} x {height} image")
                if img.mode not in _CONVERT:
                    raise InputError(f"{p}: unsupported PNG pixel mode {img.mode} (16-bit or "
                                     "other); save the map as an 8-bit grey, RGB or RGBA PNG")
                target = _CONVERT[img.mode] or ("RGBA" if "transparency" in img.info else "RGB")
                img.load()
                arr = np.asarray(img.convert(target) if target != img.mode else img)
    except InputError:
        raise
    except UnidentifiedImageError:
        raise InputError(f"{p}: not an image (Pillow cannot identify it)") from None
    except Image.DecompressionBombError as err:
        raise InputError(f"{p}: image too large: {err}") from None
    except (OSError, SyntaxError, ValueError, EOFError) as err:
        raise InputError(f"{p}: broken PNG image: {err}") from None
    arr = arr.astype(np.float64)
    if arr.ndim == 2:
        return arr, None
    has_alpha = target in ("LA", "RGBA")
    colour = arr[..., :-1] if has_alpha else arr
    return colour.mean(axis=2), (arr[..., -1] if has_alpha else None)


def encode_png(pixels: np.ndarray) -> bytes:
    """8-bit greyscale PNG bytes of (height, width) uint8 pixels, top image row first."""
    from PIL import Image
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG")
    return buf.getvalue()
