"""summary.md and summary.csv from the rows of results.json, in the reference study's layout.

Table 1 of the study: rows = worlds, columns = algorithms, cells "mean ± std" of ADNN in
cells. Table 2: per world and algorithm, precision and sensitivity "mean ± std". We add the
same at a tolerance of 1 cell, ATE, RPE and the real-time factor; the oracle (maps with the
true poses) is the last column: the ceiling a SLAM could reach with perfect poses.
Statistics use the rows with status "ok"; std is the sample standard deviation (ddof=1,
0 for a single repeat); failures are counted in their own table.
"""
from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from worlds.yamlio import atomic_write_text

__all__ = ["aggregate", "summary_markdown", "summary_csv", "write_tables", "mean_std",
           "algo_order", "world_order", "CSV_METRICS"]

# metric -> (label, decimals) of every metric in summary.csv
CSV_METRICS = {
    "adnn_cells": ("ADNN (cells)", 2), "adnn_m": ("ADNN (m)", 4),
    "adnn_reverse_cells": ("reverse ADNN (cells)", 2), "chamfer_cells": ("chamfer (cells)", 2),
    "precision": ("precision", 3), "sensitivity": ("sensitivity", 3), "f1": ("F1", 3),
    "precision_t1": ("precision, 1 cell", 3), "sensitivity_t1": ("sensitivity, 1 cell", 3),
    "precision_t2": ("precision, 2 cells", 3), "sensitivity_t2": ("sensitivity, 2 cells", 3),
    "ate_m": ("ATE (m)", 3), "ate_start_m": ("ATE from start (m)", 3),
    "rpe_trans_m": ("RPE (m)", 4), "rpe_rot_rad": ("RPE (rad)", 4),
    "realtime_factor": ("real-time factor", 1), "wall_time_s": ("wall time (s)", 1),
}


def mean_std(values) -> tuple[float, float, int]:
    """(mean, sample std, n) of the finite values; NaNs when there are none."""
    v = np.asarray([x for x in values if x is not None], dtype=np.float64)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return float("nan"), float("nan"), 0
    return float(v.mean()), float(v.std(ddof=1)) if len(v) > 1 else 0.0, len(v)


def algo_order(algos) -> list[str]:
    """pf, gn, graph, others alphabetically, the oracle last (the ceiling column)."""
    algos = list(dict.fromkeys(algos))
    head = [a for a in ("pf", "gn", "graph") if a in algos]
    rest = sorted(a for a in algos if a not in head and a != "oracle")
    return head + rest + (["oracle"] if "oracle" in algos else [])


def world_order(rows: list[dict], run: dict | None = None) -> list[str]:
    """Worlds in the order the run named them (run.json), then any others as they appear."""
    named = list((run or {}).get("worlds", {}))
    seen = set(r["world"] for r in rows)
    return [w for w in named if w in seen] + [w for w in dict.fromkeys(r["world"] for r in rows)
                                              if w not in named]


def aggregate(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """(world, algo) -> {"n", "failed", "errors", metric: (mean, std, n) for CSV_METRICS}."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["world"], r["algo"]), []).append(r)
    out = {}
    for key, rs in groups.items():
        ok = [r for r in rs if r.get("status") == "ok"]
        agg = {"n": len(rs), "failed": len(rs) - len(ok),
               "errors": sorted({str(r.get("error")) for r in rs if r.get("status") != "ok"})}
        for m in CSV_METRICS:
            agg[m] = mean_std(r.get(m) for r in ok)
        out[key] = agg
    return out


def _cell(stat, decimals: int) -> str:
    mean, std, n = stat
    if n == 0 or not math.isfinite(mean):
        return "–"
    return f"{mean:.{decimals}f} ± {std:.{decimals}f}"


def _head(algo: str) -> str:
    return "oracle (ceiling)" if algo == "oracle" else algo


def _table(worlds, algos, agg, metrics: list[tuple[str, str]], decimals: int) -> str:
    """Markdown table: one row per world, one column per algorithm x metric."""
    multi = len(metrics) > 1
    cols = [f"{_head(a)} {lab}" if multi else _head(a) for a in algos for _, lab in metrics]
    lines = ["| world | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for w in worlds:
        cells = []
        for a in algos:
            g = agg.get((w, a))
            for m, _ in metrics:
                c = _cell(g[m], decimals) if g else "–"
                if g and g["failed"] and m == metrics[0][0]:
                    c += f" ({g['failed']}/{g['n']} failed)"
                cells.append(c)
        lines.append(f"| {w} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def summary_markdown(rows: list[dict], run: dict | None = None,
                     figures: dict[str, str] | None = None) -> str:
    """The text of summary.md (see the module docstring); figures: caption -> relative path."""
    worlds = world_order(rows, run)
    algos = algo_order(r["algo"] for r in rows)
    agg = aggregate(rows)
    spec = (run or {}).get("spec", {})
    n_ok = sum(r.get("status") == "ok" for r in rows)
    out = ["# Benchmark summary", ""]
    if spec:
        out.append(f"Worlds: {', '.join(worlds)}. Algorithms: {', '.join(algos)}. "
                   f"Repeats: {spec.get('repeats')} (vary {spec.get('vary')}, base seed "
                   f"{spec.get('seed')}, noise {spec.get('noise')}).")
    vers = (run or {}).get("versions")
    if vers:
        out.append("Versions: " + ", ".join(f"{k} {v}" for k, v in vers.items()) + ".")
    ceiling = " The oracle maps with the true poses: the ceiling." if "oracle" in algos else ""
    out += [f"Rows: {len(rows)} ({len(rows) - n_ok} failed). Cells: mean ± std over the repeats "
            f"that succeeded (sample std).{ceiling}", ""]
    sections = [
        ("Table 1: ADNN (cells), mean ± std", [("adnn_cells", "")], 2),
        ("Table 2: precision (P) and sensitivity (S) of occupied cells, mean ± std",
         [("precision", "P"), ("sensitivity", "S")], 3),
        ("Table 2b: precision and sensitivity at a tolerance of 1 cell",
         [("precision_t1", "P"), ("sensitivity_t1", "S")], 3),
        ("Absolute trajectory error (m, after SE(2) alignment)", [("ate_m", "")], 3),
        ("Relative pose error (m per 1 m segment)", [("rpe_trans_m", "")], 4),
        ("Real-time factor (log duration / wall time; > 1 is faster than real time)",
         [("realtime_factor", "")], 1),
    ]
    for title, metrics, dec in sections:
        out += [f"## {title}", "", _table(worlds, algos, agg, metrics, dec), ""]
    failed = [(k, g) for k, g in agg.items() if g["failed"]]
    if failed:
        out += ["## Failures", "", "| world | algorithm | failed | errors |", "|---|---|---|---|"]
        for (w, a), g in sorted(failed):
            errs = "; ".join(g["errors"])[:300].replace("|", "/")
            out.append(f"| {w} | {a} | {g['failed']}/{g['n']} | {errs} |")
        out.append("")
    if figures:
        out += ["## Figures", ""]
        for caption, rel in figures.items():
            out.append(f"- [{caption}]({rel})")
        out.append("")
    return "\n".join(out)


def summary_csv(rows: list[dict], run: dict | None = None) -> str:
    """CSV text: one line per world x algorithm, n, failed, mean and std of every metric."""
    agg = aggregate(rows)
    worlds = world_order(rows, run)
    algos = algo_order(r["algo"] for r in rows)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["world", "algo", "n", "failed"] +
               [f"{m}_{s}" for m in CSV_METRICS for s in ("mean", "std")])
    for world in worlds:
        for algo in algos:
            g = agg.get((world, algo))
            if not g:
                continue
            vals = []
            for m in CSV_METRICS:
                mean, std, n = g[m]
                vals += ["" if n == 0 else f"{mean:.6g}", "" if n == 0 else f"{std:.6g}"]
            w.writerow([world, algo, g["n"], g["failed"]] + vals)
    return buf.getvalue()


def write_tables(out_dir: str | Path, rows: list[dict], run: dict | None = None,
                 figures: dict[str, str] | None = None) -> Path:
    """Write DIR/summary.md and DIR/summary.csv; returns the path of summary.md."""
    out_dir = Path(out_dir)
    md = out_dir / "summary.md"
    atomic_write_text(md, summary_markdown(rows, run, figures))
    atomic_write_text(out_dir / "summary.csv", summary_csv(rows, run))
    return md
