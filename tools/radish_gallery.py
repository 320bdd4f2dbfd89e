"""Maps of the corrected Radish logs by every SLAM, with ground-truth-free scores: the README gallery.

    python tools/radish_gallery.py [--data DIR] [--logs intel,aces,...] [--algo graph,pf,gn]
                                           [--out docs/gallery] [--max-px 700] [--seed S]

For each log whose timestamps are usable (LOGS below) and each algorithm, imports the log
(sim.logs.carmen), runs the algorithm with its defaults (derived from the log), writes
OUT/<log>_<algo>.png (the map, unknown grey, with the trajectory; at most --max-px pixels a
side, a small PNG) and scores the map with metrics.gtfree (occupied and free fractions,
corners, enclosed areas; Filatov et al. 2017: a blurred or doubled map has more of them).
Writes OUT/gallery.json and OUT/gallery.md (a Markdown table with the pictures).
The odometry fields of these logs are the corrected poses (GMapping's output), so algorithms
that use odometry start from a near-perfect prior; gn uses none. The column `poses` maps the
scans at those poses as the oracle maps (the reference the others are seen against: a
corridor it bends, GMapping bent), and each row gives the trajectory's ATE against them.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sim.logs import import_log  # noqa: E402
from worlds.yamlio import InputError  # noqa: E402

DEFAULT_DATA = ROOT.parent / "shared" / "data" / "radish"
# name -> file under DATA; the logs whose timestamps survive import (see the data README)
LOGS = {
    "intel": "corrected/intel-corrected.log.gz",
    "aces": "corrected/aces-corrected.log.gz",
    "fr079": "corrected/freiburg-079-corrected.log.gz",
    "fr101": "corrected/freiburg-101-corrected.log.gz",
    "edmonton": "corrected/edmonton-corrected.log.gz",
    "fhw": "corrected/fhw-corrected.log.gz",
    "acapulco": "corrected/acapulco-corrected.log.gz",
    "seattle": "corrected/seattle-corrected.log.gz",
    "csail": "csail.robotlaser1.log",
}
POSES = "poses"      # not an algorithm: the log's own (corrected) poses, mapped as the oracle maps


def save_map_png(grid, poses: np.ndarray, path: Path, title: str, max_px: int = 700) -> None:
    """The map (free white, occupied black, unknown grey) cropped to its occupied cells and the
    trajectory (N, 3) plus 2 m (long free rays would otherwise shrink the building to a dot),
    with the trajectory in red, as a PNG of at most max_px pixels a side."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    prob = np.asarray(grid.prob, dtype=np.float64)
    known = np.isfinite(prob)
    if not known.any():
        raise InputError(f"{title}: the map is empty")
    res = grid.resolution
    occ = known & (prob >= 0.65)
    rr, cc = np.nonzero(occ if occ.any() else known)
    tc = (poses[:, 0] - grid.origin[0]) / res
    tr = (poses[:, 1] - grid.origin[1]) / res
    pad = int(round(2.0 / res))
    r0 = max(int(min(rr.min(), tr.min())) - pad, 0)
    r1 = min(int(max(rr.max(), tr.max())) + pad + 1, prob.shape[0])
    c0 = max(int(min(cc.min(), tc.min())) - pad, 0)
    c1 = min(int(max(cc.max(), tc.max())) + pad + 1, prob.shape[1])
    img = np.where(known, 1.0 - prob, 0.5)[r0:r1, c0:c1]
    # shrink by taking the darkest cell of each k x k block: one-cell walls stay visible
    k = int(np.ceil(max(img.shape) / max_px))
    if k > 1:
        h, w = img.shape
        pad_img = np.full((-(-h // k) * k, -(-w // k) * k), 0.5)
        pad_img[:h, :w] = img
        img = pad_img.reshape(pad_img.shape[0] // k, k, pad_img.shape[1] // k, k).min(axis=(1, 3))
        r1, c1 = r0 + img.shape[0] * k, c0 + img.shape[1] * k
    ox, oy = grid.origin[0] + c0 * res, grid.origin[1] + r0 * res
    extent = [ox, ox + (c1 - c0) * res, oy, oy + (r1 - r0) * res]
    h, w = img.shape
    scale = min(1.0, max_px / max(h, w))
    dpi = 100
    fig = plt.figure(figsize=(max(w * scale, 200) / dpi, max(h * scale, 200) / dpi + 0.3), dpi=dpi)
    ax = fig.add_axes([0.0, 0.0, 1.0, 1.0 - 0.3 * dpi / (max(h * scale, 200) + 0.3 * dpi)])
    ax.imshow(img, cmap="gray", origin="lower", extent=extent, vmin=0.0, vmax=1.0,
              interpolation="nearest")
    ax.plot(poses[:, 0], poses[:, 1], "-", color="tab:red", lw=0.6, alpha=0.8)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_axis_off()
    fig.suptitle(title, fontsize=8, y=0.995, va="top")
    fig.savefig(path, dpi=dpi, pil_kwargs={"optimize": True})
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=str(DEFAULT_DATA))
    ap.add_argument("--logs", default=",".join(LOGS), help=f"comma-separated, from: {', '.join(LOGS)}")
    ap.add_argument("--algo", default=None, help=f"comma-separated (default gn,graph,pf,{POSES})")
    ap.add_argument("--out", default=str(ROOT / "docs" / "gallery"))
    ap.add_argument("--max-px", type=int, default=700)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    try:
        return run(Path(args.data), args.logs, args.algo, Path(args.out), args.max_px, args.seed)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


def run(data: Path, logs: str, algos: str | None, out: Path, max_px: int, seed: int) -> int:
    from dataclasses import replace

    from metrics import ate_rpe
    from metrics.gtfree import gtfree_metrics
    from slam.registry import names as algorithm_names
    from slam.replay import run_algorithm

    known = algorithm_names() + [POSES]
    names = [a.strip() for a in (algos or f"gn,graph,pf,{POSES}").split(",") if a.strip()]
    out.mkdir(parents=True, exist_ok=True)
    index = out / "gallery.json"
    rows = json.loads(index.read_text()) if index.exists() else []
    for log_name in [s.strip() for s in logs.split(",") if s.strip()]:
        if log_name not in LOGS:
            raise InputError(f"unknown log '{log_name}' (known: {', '.join(LOGS)})")
        log = import_log(data / LOGS[log_name])
        for name in names:
            if name not in known:
                print(f"{log_name} {name}: not registered, skipped", flush=True)
                continue
            t0 = time.perf_counter()
            png = out / f"{log_name}_{name}.png"
            try:
                if name == POSES:
                    result = run_algorithm("oracle", replace(log, gt_t=log.odom_t, gt_pose=log.odom_pose))
                else:
                    result = run_algorithm(name, log, seed=seed)
            except InputError as err:     # a lost algorithm is a result: a row with its reason
                png.unlink(missing_ok=True)
                row = {"log": log_name, "algo": name, "scans": int(log.n_scans),
                       "duration_s": float(log.duration), "failed": str(err)}
                rows = [r for r in rows if not (r["log"] == log_name and r["algo"] == name)] + [row]
                print(f"{log_name} {name}: failed: {row['failed']}", flush=True)
                index.write_text(json.dumps(rows, indent=1))
                continue
            wall = time.perf_counter() - t0
            save_map_png(result.grid, result.poses, png,
                         f"{log_name} - {name} ({log.n_scans} scans, {wall:.0f} s)", max_px)
            row = {"log": log_name, "algo": name, "scans": int(log.n_scans),
                   "duration_s": float(log.duration), "wall_time_s": wall,
                   "realtime_factor": float(log.duration / wall), "png": png.name,
                   "png_bytes": png.stat().st_size,
                   "ate_to_log_poses_m": ate_rpe(result.times, result.poses, log.odom_t, log.odom_pose).ate_m,
                   **gtfree_metrics(result.grid)}
            rows = [r for r in rows if not (r["log"] == log_name and r["algo"] == name)] + [row]
            print(f"{log_name} {name}: {wall:.1f} s ({row['realtime_factor']:.0f}x), "
                  f"occupied {row['occupied_fraction']:.3f}, corners {row['corners']}, "
                  f"enclosed {row['enclosed_areas']}, {row['png_bytes'] // 1024} kB", flush=True)
            index.write_text(json.dumps(rows, indent=1))
    (out / "gallery.md").write_text(format_gallery(rows) + "\n")
    return 0


def format_gallery(rows: list[dict]) -> str:
    """Markdown: a score table and a picture grid (one row per log, one column per algorithm)."""
    algos = sorted({r["algo"] for r in rows})
    logs = list(dict.fromkeys(r["log"] for r in rows))
    rows = sorted(rows, key=lambda r: (logs.index(r["log"]), r["algo"]))   # a log's rows together
    lines = ["| log | algorithm | scans | data (s) | wall (s) | × real time | ATE to the log's poses (m) | "
             "occupied | free | corners | enclosed areas |", "|" + "---|" * 11]
    for r in rows:
        if "failed" in r:
            lines.append(f"| {r['log']} | {r['algo']} | {r['scans']} | {r['duration_s']:.0f} | "
                         f"failed: {r['failed'][:120]} | | | | | | |")
            continue
        ate = f"{r['ate_to_log_poses_m']:.3f}" if "ate_to_log_poses_m" in r else "-"
        lines.append(f"| {r['log']} | {r['algo']} | {r['scans']} | {r['duration_s']:.0f} | "
                     f"{r['wall_time_s']:.1f} | {r['realtime_factor']:.0f} | {ate} | "
                     f"{r['occupied_fraction']:.3f} | {r['free_fraction']:.3f} | {r['corners']} | "
                     f"{r['enclosed_areas']} |")
    lines += ["", "| log | " + " | ".join(algos) + " |", "|---|" + "---|" * len(algos)]
    by = {(r["log"], r["algo"]): r for r in rows}
    for lg in logs:
        cells = [f"![{lg} {a}]({by[(lg, a)]['png']})" if "png" in by.get((lg, a), {}) else
                 "failed" if (lg, a) in by else "-" for a in algos]
        lines.append(f"| {lg} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
