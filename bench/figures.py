"""The report's pictures, drawn from results.json and the arrays under DIR/maps.

- overlay_<world>_<algo>.png: TP/FP/FN of the median repeat (by the main F1: the surface
  form's, or the study's cell rule's where a world has no surfaces; bench.tables.main_key),
  drawn by metrics.save_overlay_png with the alignment the scorer found (the study's Fig. 2);
- trajectories_<world>.png: the true path and each algorithm's median run over the true map;
- precision_sensitivity.png: the main precision and sensitivity per world and algorithm,
  bars = mean, error bars = std over the repeats.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from worlds.grid import Grid
from metrics.plot import save_figure
from bench.tables import aggregate, algo_order, main_key, surface_label, surface_worlds, world_order

__all__ = ["median_row", "load_grid", "write_figures"]


def median_row(rows: list[dict], key: str = "f1") -> dict | None:
    """The ok row with the median `key` (lower median for an even count); None if none is ok."""
    ok = [r for r in rows if r.get("status") == "ok" and r.get(key) is not None
          and r.get("map_file")]
    if not ok:
        return None
    ok.sort(key=lambda r: (r[key], r["repeat"]))
    return ok[(len(ok) - 1) // 2]


def load_grid(path: Path) -> Grid:
    with np.load(path) as z:
        return Grid(z["prob"], float(z["resolution"]), z["origin"])


def _overlay(out_dir: Path, fig_dir: Path, row: dict, truth: Grid, by: str) -> Path:
    import metrics
    est = load_grid(out_dir / row["map_file"])
    align = {k: float(row.get(f"align_{k}") or 0.0) for k in ("x", "y", "yaw")}
    path = fig_dir / f"overlay_{row['world']}_{row['algo']}.png"
    title = f"{row['world']} / {row['algo']}, median repeat ({row['repeat']}) by {by}"  # P/S/F1 drawn by metrics
    metrics.save_overlay_png(est, truth, align, str(path), title=title)
    return path


def _trajectories(out_dir: Path, fig_dir: Path, world: str, medians: dict[str, dict],
                  truth: Grid) -> Path:
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 6))
    occ = np.where(truth.occupied(), 0.0, 1.0)
    ax.imshow(occ, origin="lower", extent=truth.extent(), cmap="gray", vmin=0, vmax=1,
              interpolation="nearest")
    seeds = {r["log_seed"] for r in medians.values()}
    for seed in sorted(seeds):
        gt = out_dir / "maps" / world / f"gt_s{seed}.npz"
        if gt.exists():
            with np.load(gt) as z:
                p = z["poses"]
            ax.plot(p[:, 0], p[:, 1], "k--", lw=1.5, label="truth" + (f" (log seed {seed})" if len(seeds) > 1 else ""))
    for algo, row in medians.items():
        with np.load(out_dir / row["map_file"]) as z:
            p = z["poses"]
        if len(p) == 0:
            continue  # an outside map added without its trajectory
        ax.plot(p[:, 0], p[:, 1], lw=1.0, label=f"{algo} (repeat {row['repeat']})")
    ax.set_title(f"{world}: trajectories of the median runs")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.legend(fontsize=7, loc="best")
    path = fig_dir / f"trajectories_{world}.png"
    save_figure(fig, path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def _bars(fig_dir: Path, rows: list[dict], run: dict | None) -> Path:
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    agg = aggregate(rows)
    worlds = world_order(rows, run)
    algos = algo_order(r["algo"] for r in rows)
    width_in = min(14.0, max(6.0, 0.35 * len(worlds) * max(1, len(algos)) + 2.0))
    fig, axes = plt.subplots(2, 1, figsize=(width_in, 6), sharex=True)
    width = 0.8 / max(1, len(algos))
    x = np.arange(len(worlds))
    surface = surface_worlds(rows)
    for ax, metric in zip(axes, ("precision", "sensitivity")):
        for i, a in enumerate(algos):
            stats = [agg.get((w, a), {}).get(main_key(metric, w, surface), (np.nan, np.nan, 0))
                     for w in worlds]
            means = [s[0] for s in stats]
            stds = [s[1] for s in stats]
            ax.bar(x + (i - (len(algos) - 1) / 2) * width, means, width, yerr=stds, capsize=2,
                   label=a)
        ax.set_ylabel(metric)
        ax.set_ylim(0, 1.05)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=8, ncol=len(algos))
    cell = [w for w in worlds if w not in surface]
    note = "; marked *: the study's cell rule (no surfaces)" if cell else ""
    axes[0].set_title(f"Precision and sensitivity ({surface_label(rows)}{note}), mean ± std "
                      "over repeats")
    axes[-1].set_xticks(x)
    axes[-1].set_xticklabels([w + (" *" if w in cell else "") for w in worlds], rotation=20)
    path = fig_dir / "precision_sensitivity.png"
    save_figure(fig, path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def write_figures(out_dir: str | Path, rows: list[dict], run: dict | None = None) -> dict[str, str]:
    """Draw every figure into DIR/figures; returns caption -> path relative to DIR.

    A figure that cannot be drawn (missing map file, a metrics error) is skipped with a
    warning: the tables are still worth having.
    """
    out_dir = Path(out_dir)
    fig_dir = out_dir / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    made: dict[str, str] = {}
    surface = surface_worlds(rows)

    def attempt(caption, fn, *args):
        try:
            p = fn(*args)
            made[caption] = str(Path(p).relative_to(out_dir))
        except Exception as err:  # a picture is not worth losing the report over
            warnings.warn(f"figure '{caption}' skipped: {type(err).__name__}: {err}", stacklevel=2)

    if any(r.get("status") == "ok" for r in rows):
        attempt("precision and sensitivity per world and algorithm", _bars, fig_dir, rows, run)
    for w in world_order(rows, run):
        tp = out_dir / "maps" / w / "truth.npz"
        if not tp.exists():
            continue
        truth = load_grid(tp)
        medians = {}
        f1 = main_key("f1", w, surface)
        by = "F1 (surface form)" if f1 != "f1" else "F1 (the study's cell rule)"
        for a in algo_order(r["algo"] for r in rows if r["world"] == w):
            row = median_row([r for r in rows if r["world"] == w and r["algo"] == a], f1)
            if row is not None and (out_dir / row["map_file"]).exists():
                medians[a] = row
                attempt(f"TP/FP/FN overlay, {w}, {a} (median repeat {row['repeat']})",
                        _overlay, out_dir, fig_dir, row, truth, by)
        if medians:
            attempt(f"trajectories, {w}", _trajectories, out_dir, fig_dir, w, medians, truth)
    return made
