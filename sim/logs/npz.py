"""The sensor log's file: one versioned .npz (docs/formats.md), written and read here.

File: a zip of .npy entries, a JSON string `meta` and the arrays of sim.logs.sensorlog
(scan_t, scan_ranges, ..., gt_pose), written with fixed zip timestamps so the same log gives
the same bytes.

Reading checks each member's declared uncompressed size against its .npy header before any
array is read (a few kB of zip can declare gigabytes): the arrays together may take at most
MAX_LOG_BYTES as float64, meta at most MAX_META_CHARS characters nested MAX_JSON_DEPTH deep
(worlds.jsonio). Values are checked by sim.logs.checks on writing and on reading.
"""
from __future__ import annotations

import io
import json
import math
import zipfile
import zlib
from pathlib import Path

import numpy as np

from worlds.jsonio import MAX_JSON_DEPTH, deeper_than, loads
from worlds.yamlio import InputError, atomic_write_bytes, short
from sim.logs.checks import log_problem
from sim.logs.sensorlog import ARRAYS, SensorLog, shape_problem, value_problem

__all__ = ["read_log", "write_log", "FORMAT_VERSION", "MAX_LOG_BYTES", "MAX_META_CHARS"]

FORMAT_VERSION = 1
# the arrays of one log, as float64: 2 GiB holds an hour of a 1080-beam lidar at 40 Hz
# (1.2 GB) and is some 180 times the largest simulated log (swirl_l, 12 MB)
MAX_LOG_BYTES = 2 * 1024 ** 3
# sensor arrays deflate by less than 10x (the cached logs: 3.5-9x); a large member that
# inflates 200x is a bomb meant to fill memory below MAX_LOG_BYTES
_BOMB_RATIO = 200
_BOMB_MIN_BYTES = 64 * 1024 ** 2
# the simulator writes 1-2 kB of meta; importers a few kB more
MAX_META_CHARS = 1_000_000
# zlib level of the .npz entries: most arrays are float noise that higher levels barely
# shrink (a few % for 3x the time); np.load reads any level
_DEFLATE_LEVEL = 1
# an entry whose first _PROBE bytes deflate by less than _MIN_GAIN is stored uncompressed
# (white sensor noise: deflating it costs time and saves nothing)
_PROBE = 1 << 14
_MIN_GAIN = 0.05


def write_log(log: SensorLog, path: str | Path) -> None:
    """Write `log` to an .npz atomically (a Ctrl-C never leaves half a file); a log whose values
    break the rules of sim.logs.checks raises InputError naming the file and the first bad
    value."""
    problem = value_problem(log)
    if problem:
        raise InputError(f"{path}: {problem}")
    meta = dict(log.meta)
    meta["format_version"] = FORMAT_VERSION
    _check_writable_size(log, meta, str(path))
    buf = io.BytesIO()
    arrays = {name: getattr(log, name) for name in ARRAYS}
    # fixed zip timestamps and no compression metadata drift: same data, same bytes
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        entries = [("meta", np.array(json.dumps(meta, sort_keys=True)))] + list(arrays.items())
        for name, arr in entries:
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            npy = io.BytesIO()
            np.lib.format.write_array(npy, np.ascontiguousarray(arr), allow_pickle=False)
            data = npy.getvalue()
            if not _deflates(data):
                info.compress_type = zipfile.ZIP_STORED
            zf.writestr(info, data, compresslevel=_DEFLATE_LEVEL)
    atomic_write_bytes(path, buf.getvalue())


def _check_writable_size(log: SensorLog, meta: dict, where: str) -> None:
    """InputError when read_log would refuse the log for its size (MAX_LOG_BYTES,
    MAX_META_CHARS, MAX_JSON_DEPTH): a writer must not make a file its own reader refuses."""
    size = sum(getattr(log, n).nbytes for n in ARRAYS)
    if size > MAX_LOG_BYTES:
        raise InputError(f"{where}: the log's arrays take {size:,} bytes, more than the "
                         f"{MAX_LOG_BYTES:,} a sensor log may hold")
    if deeper_than(meta, MAX_JSON_DEPTH):
        raise InputError(f"{where}: meta: JSON nested deeper than {MAX_JSON_DEPTH} levels")
    meta_text = json.dumps(meta, sort_keys=True)
    if len(meta_text) > MAX_META_CHARS:
        raise InputError(f"{where}: meta: {len(meta_text):,} characters, more than the "
                         f"{MAX_META_CHARS:,} a log's meta may have")


def _deflates(data: bytes) -> bool:
    """Whether deflating `data` is worth it, judged on its first _PROBE bytes."""
    probe = data[:_PROBE]
    return len(zlib.compress(probe, _DEFLATE_LEVEL)) < (1.0 - _MIN_GAIN) * len(probe)


def _member_header(zf: zipfile.ZipFile, info: zipfile.ZipInfo, where: str):
    """(shape, dtype) from the .npy header of a zip member, read without its data;
    InputError naming the member when its declared uncompressed size (ZipInfo.file_size) is
    not what that array needs, or it holds Python objects."""
    with zf.open(info) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
        else:
            raise InputError(f"{where}: {info.filename}: .npy format version "
                             f"{version[0]}.{version[1]} is not read (1.0 and 2.0 are)")
        header = fh.tell()
    if dtype.hasobject:
        raise InputError(f"{where}: {info.filename}: holds Python objects (a pickle), not numbers")
    need = header + math.prod(shape) * dtype.itemsize
    if info.file_size != need:   # more: a bomb behind a small header; less: cut short
        raise InputError(f"{where}: {info.filename}: declares {info.file_size:,} bytes "
                         f"uncompressed, its {shape} {dtype} array needs {need:,}")
    return shape, dtype


def _checked_shapes(zf: zipfile.ZipFile, where: str) -> dict[str, tuple]:
    """name -> shape of the log's arrays, from their headers: InputError before any array is
    read when a member is missing, is not made of numbers, the arrays disagree in shape
    (sim.logs.sensorlog's rules) or would take more than MAX_LOG_BYTES as float64."""
    present = set(zf.namelist())
    missing = [n for n in ARRAYS if f"{n}.npy" not in present]
    if missing:
        raise InputError(f"{where}: missing arrays: {', '.join(missing)}")
    shapes, total = {}, 0
    for name in ARRAYS:
        info = zf.getinfo(f"{name}.npy")
        if info.file_size > _BOMB_MIN_BYTES and info.file_size > _BOMB_RATIO * info.compress_size:
            raise InputError(f"{where}: {info.filename}: {info.compress_size:,} compressed bytes "
                             f"inflate to {info.file_size:,}, more than {_BOMB_RATIO} times: a zip "
                             "bomb, not sensor data")
        shape, dtype = _member_header(zf, info, where)
        if dtype.kind not in "biuf":
            raise InputError(f"{where}: {info.filename}: expected numbers, got dtype {dtype}")
        total += math.prod(shape) * 8   # read as float64
        if total > MAX_LOG_BYTES:
            raise InputError(f"{where}: {info.filename}: its {shape} array brings the log to "
                             f"{total:,} bytes, more than the {MAX_LOG_BYTES:,} a sensor log "
                             "may hold")
        shapes[name] = shape
    # zero-stride views: the shape rules checked without allocating the arrays
    problem = shape_problem({n: np.broadcast_to(np.float64(0.0), s) for n, s in shapes.items()})
    if problem:
        raise InputError(f"{where}: {problem}")
    return shapes


def _read_meta(zf: zipfile.ZipFile, where: str) -> dict:
    """The log's meta mapping from its `meta.npy` (a JSON string), size and depth checked."""
    if "meta.npy" not in zf.namelist():
        raise InputError(f"{where}: not a sensor log: no 'meta' entry")
    info = zf.getinfo("meta.npy")
    shape, dtype = _member_header(zf, info, where)
    if dtype.kind not in "US" or math.prod(shape) != 1:
        raise InputError(f"{where}: meta: expected one JSON string, got a {shape} {dtype} array")
    chars = dtype.itemsize // (4 if dtype.kind == "U" else 1)
    if chars > MAX_META_CHARS:
        raise InputError(f"{where}: meta: {chars:,} characters, more than the "
                         f"{MAX_META_CHARS:,} a log's meta may have")
    with zf.open(info) as fh:
        text = np.lib.format.read_array(fh, allow_pickle=False).reshape(-1)[0]
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    meta = loads(str(text), f"{where}: meta")
    if not isinstance(meta, dict):
        raise InputError(f"{where}: meta: expected a mapping, got {type(meta).__name__}")
    return meta


def read_log(path: str | Path) -> SensorLog:
    """Read and check a sensor log; a bad file raises InputError naming it and the problem.

    Sizes and shapes are checked from the members' headers before any array is read (module
    docstring); values are checked by sim.logs.checks.
    """
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: file not found")
    try:
        with zipfile.ZipFile(p) as zf:
            meta = _read_meta(zf, str(p))
            version = meta.get("format_version")
            if not isinstance(version, int) or isinstance(version, bool) or version < 1:
                raise InputError(f"{p}: meta.format_version: expected an integer >= 1, "
                                 f"got {short(version)}")
            if version > FORMAT_VERSION:
                raise InputError(f"{p}: meta.format_version: {version} is newer than this "
                                 f"reader (reads up to {FORMAT_VERSION}); upgrade the package")
            _checked_shapes(zf, str(p))
            arrays = {}
            for name in ARRAYS:
                with zf.open(f"{name}.npy") as fh:
                    arrays[name] = np.asarray(np.lib.format.read_array(fh, allow_pickle=False),
                                              dtype=np.float64)
    except InputError:
        raise
    except Exception as err:   # any damage zip or npy parsing can meet
        reason = " ".join(str(err).split()) or type(err).__name__
        raise InputError(f"{p}: not a readable sensor log (.npz): {reason}") from None
    problem = shape_problem(arrays) or log_problem(arrays, meta)
    if problem:
        raise InputError(f"{p}: {problem}")
    return SensorLog(**arrays, meta=meta)
