"""DIR/results.json: one row per world x algorithm x repeat, rewritten atomically as rows finish.

The file is a JSON object {"format": 1, "rows": [...]} with rows sorted by (world, algo, repeat),
so an interrupted-and-resumed run and an uninterrupted run give the same file up to timing
fields (`TIMING_FIELDS`, see `comparable`). Every append rewrites the whole file through a
temporary file and os.replace: a Ctrl-C or a killed process leaves the previous complete file.

Reading checks what later steps trust (`read_rows`, `read_run`): a UTF-8 JSON object of at
most MAX_JSON_BYTES nested at most MAX_JSON_DEPTH (worlds.jsonio) deep; rows that are mappings with
the name rule (worlds.paths) on the fields that become parts of paths, whole numbers where
file names and seeds are made of them, numbers (or null) where the tables average them, and
a `map_file` that stays inside the run folder. Anything else is one InputError naming the
file and the field (`rows[3].repeat`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

from worlds.jsonio import dumps, jsonable, read_json as _read_json
from worlds.paths import check_name, is_name
from worlds.yamlio import InputError, atomic_write_text, short

__all__ = ["ResultStore", "RESULTS_NAME", "RUN_NAME", "TIMING_FIELDS", "MAX_JSON_BYTES",
           "comparable", "read_rows", "read_run", "read_json", "run_spec", "check_row", "row_key",
           "jsonable"]

RESULTS_NAME = "results.json"
RUN_NAME = "run.json"
FORMAT = 1
# fields that differ between two runs of the same rows (machine load, dates, the machine)
TIMING_FIELDS = frozenset({"wall_time_s", "realtime_factor", "update_time_median_s",
                           "update_time_max_s", "finish_time_s", "task_time_s", "score_time_s",
                           "finished_at", "worker", "host", "cpu"})
# a row takes about 3 kB: 64 MiB hold some 20,000 rows, and parse into well under 1 GB
MAX_JSON_BYTES = 64 * 1024 * 1024
STATUSES = ("ok", "failed")
# row fields that become parts of paths (maps/<world>/<algo>/<repeat>.npz): the name rule
_NAME_FIELDS = ("world", "algo")
# whole numbers that name files (<repeat>.npz, gt_s<log_seed>.npz) or seed generators;
# repeat is required, the others may be null (an outside row has no SLAM seed)
_COUNT_FIELDS = ("repeat", "draw", "same_as")
_SEED_FIELDS = ("log_seed", "slam_seed")
_INT_LIMIT = 2 ** 63
# read as text by the tables and the report
_TEXT_FIELDS = ("error", "noise", "vary", "source", "traceback", "note", "map_file")
# numbers the tables, figures and regress read besides the registry's columns
_NUMBER_FIELDS = ("surface_tau_m", "align_x", "align_y", "align_yaw", "surface_align_x",
                  "surface_align_y", "surface_align_yaw")


def row_key(row: dict) -> tuple[str, str, int]:
    return (row["world"], row["algo"], int(row["repeat"]))


def comparable(rows: Iterable[dict]) -> list[dict]:
    """Rows without timing fields (also inside `slam_stats`), sorted: for run-vs-resume checks."""
    out = []
    for row in sorted(rows, key=row_key):
        r = {k: v for k, v in row.items() if k not in TIMING_FIELDS}
        if isinstance(r.get("slam_stats"), dict):
            r["slam_stats"] = {k: v for k, v in r["slam_stats"].items()
                               if k not in TIMING_FIELDS and "time" not in k}
        out.append(r)
    return out


def read_json(path: str | Path, what: str) -> dict:
    """The JSON object in file `path`, at most MAX_JSON_BYTES (worlds.jsonio.read_json: InputError
    naming the file when it is missing, too large, not UTF-8, not valid JSON, nested too deeply
    or not an object). what: the kind of file, for the message."""
    return _read_json(path, what, MAX_JSON_BYTES)


def read_rows(path: str | Path) -> list[dict]:
    """Rows of a results.json (a directory or the file), each checked by check_row;
    InputError on a missing or bad file, naming the file and the field."""
    p = Path(path)
    if p.is_dir():
        p = p / RESULTS_NAME
    if not p.is_file():
        raise InputError(f"{p}: file not found")
    data = read_json(p, "bench results file")
    if not isinstance(data.get("rows"), list):
        raise InputError(f"{p}: not a bench results file (no 'rows' list)")
    if data.get("format", FORMAT) != FORMAT:
        raise InputError(f"{p}: format: expected {FORMAT}, got {short(data['format'])}")
    seen: dict[tuple, int] = {}
    numbers = _number_fields()
    for i, row in enumerate(data["rows"]):
        check_row(row, str(p), f"rows[{i}]", numbers)
        key = row_key(row)
        if key in seen:
            raise InputError(f"{p}: rows[{i}]: {'/'.join(map(str, key))} again (also "
                             f"rows[{seen[key]}])")
        seen[key] = i
    return data["rows"]


def check_row(row: object, file: str, field: str = "row", numbers=None) -> None:
    """InputError '<file>: <field>.KEY: problem' unless `row` is a mapping whose fields have
    the types later steps trust (module docstring). numbers: the keys that must hold a number
    or null (default: _number_fields())."""
    if not isinstance(row, dict):
        raise InputError(f"{file}: {field}: expected a mapping (a row), got {short(row)}")
    for key in _NAME_FIELDS:
        check_name(row.get(key), file, f"{field}.{key}")
    for key in (*_COUNT_FIELDS, *_SEED_FIELDS):
        if key == "repeat" or row.get(key) is not None:
            low = 0 if key in _COUNT_FIELDS else -_INT_LIMIT
            _check_int(row.get(key), f"{file}: {field}.{key}", low)
    if row.get("status") not in STATUSES:
        raise InputError(f"{file}: {field}.status: expected one of {', '.join(STATUSES)}, got "
                         f"{short(row.get('status'))}")
    for key in _TEXT_FIELDS:
        if row.get(key) is not None and not isinstance(row[key], str):
            raise InputError(f"{file}: {field}.{key}: expected text or null, got "
                             f"{short(row[key])}")
    for key in _number_fields() if numbers is None else numbers:
        v = row.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
            raise InputError(f"{file}: {field}.{key}: expected a number or null, got {short(v)}")
    if row.get("map_file") is not None:
        _check_map_file(row["map_file"], f"{file}: {field}.map_file")


def _check_int(value: object, where: str, low: int) -> None:
    """InputError '<where>: ...' unless `value` is an integer in [low, 2**63) (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value < _INT_LIMIT:
        floor = "0" if low == 0 else "-2**63"
        raise InputError(f"{where}: expected an integer in [{floor}, 2**63), got {short(value)}")


def _check_map_file(value: str, where: str) -> None:
    """A row's map file: a relative path of names (worlds.paths), so that it stays inside the
    run folder (maps/<world>/<algo>/<repeat>.npz); '..', an absolute path or an empty part
    is refused."""
    parts = value.split("/")
    if value.startswith("/") or not all(is_name(part) for part in parts):
        raise InputError(f"{where}: {short(value)} is not a path inside the run folder (parts "
                         "of letters, digits and _ . + -, separated by /)")


def _number_fields() -> tuple[str, ...]:
    """The keys the report averages (metrics.registry's columns and their fallbacks) and the
    other numbers it reads."""
    from metrics import registry
    cols = registry.columns()
    return (*{c.key for c in cols} | {c.fallback for c in cols if c.fallback}, *_NUMBER_FIELDS)


def read_run(out_dir: str | Path) -> dict:
    """DIR/run.json as a dict; InputError if it is missing, unreadable or not a JSON object
    (read_json)."""
    p = Path(out_dir) / RUN_NAME
    if not p.is_file():
        raise InputError(f"{out_dir}: no {RUN_NAME} here: not a bench run directory")
    return read_json(p, "bench run description")


def run_spec(run: dict, where: str | Path):
    """The bench.plan.RunSpec stored in a run.json (read_run), and its world keys checked by
    the name rule; InputError naming `where` and the field when they are malformed."""
    from bench.plan import RunSpec
    spec, worlds = run.get("spec"), run.get("worlds")
    if not isinstance(spec, dict):
        raise InputError(f"{where}: spec: expected a mapping (the run's arguments), got "
                         f"{short(spec)}")
    if not isinstance(worlds, dict):
        raise InputError(f"{where}: worlds: expected a mapping (world key -> its file), got "
                         f"{short(worlds)}")
    for key, entry in worlds.items():
        check_name(key, str(where), "worlds")
        if not isinstance(entry, dict):
            raise InputError(f"{where}: worlds.{key}: expected a mapping, got {short(entry)}")
    try:
        return RunSpec.from_json(spec)
    except InputError as err:
        raise InputError(f"{where}: spec: {err}") from None
    except (TypeError, ValueError) as err:   # a field of the wrong type, e.g. worlds: 5
        raise InputError(f"{where}: spec: not a run's arguments ({err})") from None


class ResultStore:
    """The rows of one run directory; `add` stores a row and rewrites results.json atomically."""

    def __init__(self, out_dir: str | Path):
        self.dir = Path(out_dir)
        self.path = self.dir / RESULTS_NAME
        self.rows: dict[tuple, dict] = {}
        if self.path.exists():
            for row in read_rows(self.path):
                self.rows[row_key(row)] = row

    def __contains__(self, key) -> bool:
        return tuple(key) in self.rows

    def __len__(self) -> int:
        return len(self.rows)

    def add(self, row: dict) -> None:
        """Store `row` (replacing one with the same key) and persist the file."""
        row = jsonable(row)
        self.rows[row_key(row)] = row
        self.save()

    def sorted_rows(self) -> list[dict]:
        """The rows in key order (world, algo, repeat), as results.json holds them."""
        return [self.rows[k] for k in sorted(self.rows)]

    def save(self) -> None:
        rows = self.sorted_rows()
        text = dumps({"format": FORMAT, "rows": rows}, indent=1)
        atomic_write_text(self.path, text + "\n", root=self.dir)

