"""Hostile files through every command: each case must end with exit 0 or 2, at most one line
on stderr, no traceback, a peak memory under 1 GB, and no file written outside its output
folder or the log cache (the folders above are listed before and after).

    python tools/hostile_cases.py [--keep DIR]

Prints one line per case (PASS/FAIL, exit code, peak MB, seconds, the stderr line) and exits 1
when any case fails. Needs a few minutes: one small benchmark run is made first, for the
cases that read a run folder.
"""
from __future__ import annotations

import argparse
import io
import json
import os
import shutil
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np

from sim.logs.tum import write_tum


MEMORY_LIMIT_MB = 1024
TIMEOUT_S = 300
ROOM = """name: {name}
description: {description}
resolution: {resolution}
walls:
  thickness: 0.1
  polylines:
    - [[0, 0], [1.6, 0], [1.6, 1.2], [0, 1.2], [0, 0]]
obstacles:
{obstacles}
robot:
  start: [0.4, 0.4, 0]
route:
  - [1.2, 0.4]
  - [0.5, 0.8]
"""
BOMB = "".join([f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi")])


def room(name="room", description="'a room'", resolution="0.05", obstacles=None) -> str:
    """A valid small world with one field replaced."""
    obstacles = obstacles or "  - {box: {center: [1.45, 1.05], size: [0.2, 0.2]}}"
    return ROOM.format(name=name, description=description, resolution=resolution,
                       obstacles=obstacles)


def alias_bomb(key: str) -> str:
    """A world whose `key` holds ~500 bytes of nested aliases (9^9 strings expanded)."""
    head = "a: &a [x, x, x, x, x, x, x, x, x]\n" + BOMB
    return head.replace("a: &a", f"{key}: &a", 1) if key else head


def listing(root: Path, skip: Path | None = None) -> set[str]:
    """Every path under root (relative), leaving out `skip` and what lies below it."""
    out = set()
    for p in root.rglob("*"):
        if skip is not None and (p == skip or skip in p.parents):
            continue
        out.add(str(p.relative_to(root)))
    return out


def run(cmd: list[str], cwd: Path, env: dict) -> tuple[int, str, float, float]:
    """Run `python -m cmd...` in `cwd`: exit code (-9 after a timeout), stderr, the child's
    peak RSS in MB (its own rusage, from wait4) and seconds."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err, open(os.devnull, "wb") as null:
        pid = _spawn(cmd, cwd, env, null, err)
        while True:
            done, status, usage = os.wait4(pid, os.WNOHANG)
            if done:
                break
            if time.perf_counter() - t0 > TIMEOUT_S:
                os.kill(pid, 9)
                _, status, usage = os.wait4(pid, 0)
                break
            time.sleep(0.05)
        err.seek(0)
        text = err.read().decode("utf-8", "replace")
    code = os.waitstatus_to_exitcode(status)
    return code, text, usage.ru_maxrss / 1024.0, time.perf_counter() - t0


def _spawn(cmd, cwd, env, null, err) -> int:
    """Start the command in `cwd` (fork + exec, so that wait4 reports its own peak)."""
    pid = os.fork()
    if pid == 0:
        try:
            os.chdir(cwd)
            os.dup2(null.fileno(), 1)
            os.dup2(err.fileno(), 2)
            os.execve(sys.executable, [sys.executable, "-m", *cmd], env)
        finally:
            os._exit(127)
    return pid


def make_run(base: Path, env: dict) -> Path:
    """A small finished run (oracle on a small room) whose folder the run-reading cases damage."""
    world = base / "room.yaml"
    world.write_text(room())
    out = base / "run"
    code, err, _, _ = run(["bench", "run", "--world", str(world), "--algo", "oracle",
                           "--repeats", "1", "--jobs", "1", "--no-progress", "--no-figures",
                           "--out", str(out)], base, env)
    if code != 0:
        raise SystemExit(f"the base run failed: {err.strip()}")
    return out


def zip_bomb(path: Path, log: Path) -> None:
    """The log `log` whose scan_ranges and scan_angles members say (in their headers, and
    truly) that they hold 4 GB of zeros: a .npz of a few MB."""
    with np.load(log, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    scans = len(arrays["scan_t"])
    beams = 4 * 1024**3 // 8 // scans
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as out:
        for k, v in arrays.items():
            if k not in ("scan_ranges", "scan_angles"):
                out.writestr(f"{k}.npy", _npy(v))
        out.writestr("scan_angles.npy", _npy(np.linspace(-3.1, 3.1, beams)))
        with out.open("scan_ranges.npy", "w", force_zip64=True) as fh:
            fh.write(_npy_header(np.dtype("<f8"), (scans, beams)))
            chunk = bytes(1 << 24)
            left = scans * beams * 8
            while left > 0:
                fh.write(chunk[:min(left, len(chunk))])
                left -= len(chunk)


def _npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def _npy_header(dtype, shape) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": np.lib.format.dtype_to_descr(dtype),
                                               "fortran_order": False, "shape": shape})
    return buf.getvalue()


def state(root: Path, skip: Path | None = None) -> dict[str, tuple[int, int]]:
    """(size, mtime in ns) of every path under root, leaving out `skip` and below: a changed
    or new entry is a write."""
    out = {}
    for rel in listing(root, skip):
        st = (root / rel).lstat()
        # a folder's mtime changes when the output folder is made inside it: not a write
        out[rel] = (0, 0) if (root / rel).is_dir() else (st.st_size, st.st_mtime_ns)
    return out


def damaged_run(run_dir: Path, case: Path, results: str | bytes | None = None,
                run_json: str | bytes | None = None) -> Path:
    """A copy of the base run inside `case` with results.json / run.json replaced."""
    d = case / "run"
    shutil.copytree(run_dir, d)
    for name, content in (("results.json", results), ("run.json", run_json)):
        if content is not None:
            (d / name).write_bytes(content.encode() if isinstance(content, str) else content)
    return d


def rows_with(run_dir: Path, **fields) -> str:
    """The base run's results.json with `fields` set on its first row."""
    data = json.loads((run_dir / "results.json").read_text())
    data["rows"][0].update(fields)
    return json.dumps(data)


def cases(base: Path, run_dir: Path, log: Path) -> list[tuple[str, callable]]:
    """(label, setup(case_dir) -> (command, output folder or None, extra check or None))."""
    world = base / "room.yaml"
    tum = run_dir / "oracle.tum"
    deep_json = "[" * 100_000 + "]" * 100_000
    out = lambda c: c / "a" / "b" / "out"   # noqa: E731

    def write(c: Path, name: str, text: str) -> Path:
        (c / name).write_text(text)
        return c / name

    def bench_run_world(text):
        return lambda c: (["bench", "run", "--world", str(write(c, "w.yaml", text)), "--algo",
                           "oracle", "--repeats", "1", "--jobs", "1", "--no-progress",
                           "--out", str(out(c))], out(c), None)

    def render(text):
        return lambda c: (["worlds", "render", str(write(c, "w.yaml", text)), "--out",
                           str(out(c))], out(c), None)

    def suite(text):
        return lambda c: (["bench", "run", "--suite", str(write(c, "s.yaml", text)), "--algo",
                           "oracle", "--repeats", "1", "--jobs", "1", "--no-progress",
                           "--out", str(out(c))], out(c), None)

    def victim(c):
        (c / "victim.yaml").write_text("keep me\n")
        return (["worlds", "render", str(write(c, "w.yaml", room(name=str(c / "victim")))),
                 "--out", str(out(c))], out(c), None)

    def on_run(command, results=None, run_json=None, extra=()):
        def setup(c):
            d = damaged_run(run_dir, c, results, run_json)
            argv = [a.replace("RUN", str(d)) for a in command] + list(extra)
            return argv, d, None
        return setup

    def foreign_world_log(c):
        elsewhere = c / "elsewhere"
        elsewhere.mkdir()
        shutil.copy(world, elsewhere / "w.yaml")
        z = dict(np.load(log, allow_pickle=False))
        meta = json.loads(str(z["meta"][0]))
        meta.update(world="w", world_source=str(elsewhere / "w.yaml"))
        z["meta"] = np.array([json.dumps(meta)])
        (c / "logs").mkdir()
        np.savez(c / "logs" / "a.npz", **z)
        return (["bench", "run", "--logs", str(c / "logs"), "--algo", "oracle", "--jobs", "1",
                 "--no-progress", "--out", str(out(c))], out(c), None)

    def deep_meta_log(c):
        z = dict(np.load(log, allow_pickle=False))
        z["meta"] = np.array(['{"a": ' * 50_000 + "1" + "}" * 50_000])
        np.savez(c / "deep.npz", **z)
        return ["slam", "run", "--algo", "oracle", "--log", str(c / "deep.npz"), "--out",
                str(out(c))], out(c), None

    def bomb_log(c):
        zip_bomb(c / "bomb.npz", log)
        return ["slam", "run", "--algo", "oracle", "--log", str(c / "bomb.npz"), "--out",
                str(out(c))], out(c), None

    def far_tum(c):
        t = write(c, "far.tum", "0 1e308 0 0 0 0 0 1\n1 1e308 0 0 0 0 0 1\n")
        return ["metrics", "trajectory", "--est", str(t), "--truth", str(log)], None, None

    def add_far(c):
        d = damaged_run(run_dir, c)
        t = write(c, "far.tum", "0 1e308 0 0 0 0 0 1\n1 1e308 0 0 0 0 0 1\n")
        return ["bench", "add", str(d), "--world", "room", "--algo", "mine", "--trajectory",
                str(t), "--render", "--no-figures"], d, None

    def add_unknown(c):
        d = damaged_run(run_dir, c)
        (c / "m.pgm").write_bytes(b"P5\n40 30\n255\n" + bytes([205]) * 1200)
        write(c, "m.yaml", "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                           "occupied_thresh: 0.65\nfree_thresh: 0.196\n")

        def failed_row() -> str:
            rows = json.loads((d / "results.json").read_text())["rows"]
            mine = [r for r in rows if r["algo"] == "mine"]
            return "" if mine and mine[0]["status"] == "failed" else "no failed row for the map"
        return ["bench", "add", str(d), "--world", "room", "--algo", "mine", "--map",
                str(c / "m.yaml"), "--no-figures"], d, failed_row

    def regress_bad(c):
        b = c / "baseline.json"
        b.write_bytes(bytes(range(256)) * 10)
        return ["bench", "regress", "--baseline", str(b), "--out", str(out(c))], out(c), None

    def import_twice(c):
        shutil.copy(log, c / "log.npz")
        return ["sim", "import", str(c / "log.npz"), "--out", str(c / "log.npz")], None, None

    bad_rows = rows_with(run_dir, repeat="x", world=5)
    return [
        ("1 render: name is an absolute path", victim),
        ("1 bench run: name ../../../X", bench_run_world(room(name="../../../X"))),
        ("1 bench run: absolute name", bench_run_world(room(name="/tmp/hostile_abs_x"))),
        ("1 merge: map_file ../X", on_run(["bench", "merge", "RUN", "--out", "RUN/../merged"],
                                           results=rows_with(run_dir, map_file="../X"))),
        ("1 bench run --logs: world_source elsewhere", foreign_world_log),
        ("2 render: alias bomb in description", render(alias_bomb("") + room(description="*i"))),
        ("2 render: alias bomb in resolution", render(alias_bomb("") + room(resolution="*i"))),
        ("2 suite: alias bomb in name", suite(alias_bomb("") + "name: *i\nworlds: [rectangle_s]\n")),
        ("2 suite: alias bomb in draws", suite(alias_bomb("") + "draws: *i\nworlds: [rectangle_s]\n")),
        ("2 render: circle sides 1e8", render(room(
            obstacles="  - {circle: {center: [0.8, 0.9], radius: 0.1, sides: 100000000}}"))),
        ("2 render: 20,000 obstacles", render(room(obstacles="".join(
            f"  - {{box: {{center: [{0.2 + i * 6e-5:.5f}, 1.0], size: [0.01, 0.01]}}}}\n"
            for i in range(20000))))),
        ("2 suite: draws 1000000", suite("draws: 1000000\nworlds: [rectangle_s]\n")),
        ("2 slam run: zip-bombed .npz log", bomb_log),
        ("2 generate: --size 100000x100000", lambda c: (
            ["worlds", "generate", "office", "--seed", "1", "--size", "100000x100000", "--out",
             str(out(c) / "g.yaml")], out(c), None)),
        ("4 metrics trajectory: 1e308", far_tum),
        ("4 bench add: trajectory 1e308", add_far),
        ("4 bench add: all-unknown map is a failed row", add_unknown),
        ("5 merge: binary results.json", on_run(["bench", "merge", "RUN", "--out", "RUN/../m"],
                                                results=bytes(range(256)) * 10)),
        ("5 merge: deeply nested results.json", on_run(["bench", "merge", "RUN", "--out",
                                                        "RUN/../m"], results=deep_json)),
        ("5 merge: wrong-typed rows", on_run(["bench", "merge", "RUN", "--out", "RUN/../m"],
                                             results=bad_rows)),
        ("5 resume: binary run.json", on_run(["bench", "run", "--resume", "RUN", "--no-progress"],
                                             run_json=bytes(range(256)) * 10)),
        ("5 resume: deeply nested run.json", on_run(["bench", "run", "--resume", "RUN",
                                                     "--no-progress"], run_json=deep_json)),
        ("5 resume: wrong-typed rows", on_run(["bench", "run", "--resume", "RUN", "--no-progress"],
                                              results=bad_rows)),
        ("5 add: wrong-typed rows", on_run(["bench", "add", "RUN", "--world", "room", "--algo",
                                            "mine", "--trajectory", str(tum), "--render",
                                            "--no-figures"], results=bad_rows)),
        ("5 report: deeply nested results.json", on_run(["bench", "report", "RUN"],
                                                        results=deep_json)),
        ("5 regress: binary baseline", regress_bad),
        ("5 render: coordinates 1e308", render(room().replace("[1.6, 0]", "[1e308, 0]"))),
        ("5 render: 100,000-deep YAML", render("walls: " + "[" * 100_000 + "]" * 100_000)),
        ("5 slam run: deeply nested log meta", deep_meta_log),
        ("6 sim import: --out exists", import_twice),
        ("7 render: 1e5-style numbers", render(room(resolution="5e-2"))),
    ]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--keep", help="work in this folder and keep it (default: a temporary one)")
    args = ap.parse_args(argv)
    base = Path(args.keep or tempfile.mkdtemp(prefix="hostile-")).resolve()
    base.mkdir(parents=True, exist_ok=True)
    cache = base / "cache"
    env = {**os.environ, "SLAM_BENCH_CACHE": str(cache)}
    run_dir = make_run(base, env)
    log = sorted(cache.glob("room-s0-*.npz"))[0]
    shutil.copy(log, base / "room_s0.npz")
    log = base / "room_s0.npz"
    with np.load(next((run_dir / "maps" / "room" / "oracle").glob("*.npz"))) as z:
        write_tum(run_dir / "oracle.tum", z["times"], z["poses"])
    failed = 0
    print(f"{'':4} {'exit':>4} {'MB':>6} {'s':>6}  case: stderr")
    for i, (label, setup) in enumerate(cases(base, run_dir, log)):
        case = base / f"case{i:02d}"
        (case / "a" / "b").mkdir(parents=True)
        command, out_dir, check = setup(case)
        before, cached = state(base, case if out_dir is None else out_dir), state(cache)
        code, err, peak, secs = run(command, case, env)
        lines = err.strip().splitlines()
        problems = []
        if code not in (0, 2):
            problems.append(f"exit {code}")
        if len(lines) > 1 or "Traceback" in err:
            problems.append(f"{len(lines)} lines on stderr")
        if peak >= MEMORY_LIMIT_MB:
            problems.append(f"peak {peak:.0f} MB")
        # the output folder (or, for a command that writes in place, its case) is left out
        after = state(base, case if out_dir is None else out_dir)
        written = sorted(k for k in set(after) | set(before) if before.get(k) != after.get(k))
        if written:
            problems.append(f"wrote outside: {written[:3]}")
        if state(cache) != cached:
            problems.append("wrote in the cache")
        if check is not None and (why := check()):
            problems.append(why)
        failed += bool(problems)
        verdict = "FAIL" if problems else "PASS"
        first = lines[0][:150] if lines else ""
        print(f"{verdict} {code:>4} {peak:>6.0f} {secs:>6.1f}  {label}: {first}"
              + (f"  <-- {'; '.join(problems)}" if problems else ""), flush=True)
    if not args.keep:
        shutil.rmtree(base, ignore_errors=True)
    print(f"{failed} of {i + 1} cases failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
