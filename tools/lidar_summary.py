"""Per-lidar tables of a run whose worlds were crossed with lidars (`bench run --suite lidars`).

    python tools/lidar_summary.py RUN_DIR [--reference lds-01]

Reads RUN_DIR/results.json (world keys WORLD+LIDAR) and prints, per lidar and algorithm, the
mean ATE over the worlds (each world's mean over its draws) and its ratio to the reference
lidar's, the largest per-world ratio and the world it belongs to, the mean surface F1 and the
failed rows; then the oracle's mean wall coverage of each lidar's logs (the share of the true
wall cells its beams reached), which shows where a lidar sees less.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np


def _split(key: str) -> tuple[str, str]:
    world, _, lidar = key.rpartition("+")
    return (world, lidar) if world else (key, "")


def tables(rows: list[dict], reference: str) -> str:
    """The Markdown tables (see the module docstring)."""
    ate = defaultdict(list)          # (lidar, algo, world) -> ATE of each ok row
    f1 = defaultdict(list)
    failed = defaultdict(int)
    for r in rows:
        world, lidar = _split(r["world"])
        if r.get("status") != "ok":
            failed[(lidar, r["algo"])] += 1
            continue
        if r.get("ate_m") is not None:
            ate[(lidar, r["algo"], world)].append(r["ate_m"])
        if r.get("surface_f1") is not None:
            f1[(lidar, r["algo"])].append(r["surface_f1"])
    lidars = sorted({k[0] for k in ate}, key=lambda v: (v != reference, v))
    algos = sorted({k[1] for k in ate if k[1] != "oracle"})
    lines = [f"| lidar | algo | worlds | mean ATE (m) | x {reference} | worst world x {reference} "
             f"| mean surface F1 | failed rows |", "|---|---|---|---|---|---|---|---|"]
    for lidar in lidars:
        for algo in algos:
            per = {w: float(np.mean(v)) for (li, a, w), v in ate.items() if li == lidar and a == algo}
            ref = {w: float(np.mean(v)) for (li, a, w), v in ate.items() if li == reference and a == algo}
            if not per:
                continue
            mean = float(np.mean(list(per.values())))
            common = [w for w in per if w in ref and ref[w] > 0]
            ratio = mean / float(np.mean([ref[w] for w in per if w in ref])) if common else float("nan")
            worst = max(common, key=lambda w: per[w] / ref[w]) if common else None
            worst_txt = f"{per[worst] / ref[worst]:.2f} ({worst})" if worst else "-"
            lines.append(f"| {lidar} | {algo} | {len(per)} | {mean:.4f} | {ratio:.2f} | {worst_txt} | "
                         f"{np.mean(f1[(lidar, algo)]):.3f} | {failed[(lidar, algo)]} |")
    cover = defaultdict(list)
    for r in rows:
        world, lidar = _split(r["world"])
        if r["algo"] == "oracle" and r.get("status") == "ok" and r.get("surface_sensitivity") is not None:
            cover[lidar].append(r["surface_sensitivity"])
    lines += ["", "| lidar | oracle surface sensitivity, mean (min) over its logs |", "|---|---|"]
    for lidar in lidars:
        if cover[lidar]:
            lines.append(f"| {lidar} | {np.mean(cover[lidar]):.3f} ({np.min(cover[lidar]):.3f}) |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--reference", default="lds-01")
    args = ap.parse_args(argv)
    data = json.loads((args.run / "results.json").read_text())
    print(tables(data["rows"] if isinstance(data, dict) else data, args.reference))
    return 0


if __name__ == "__main__":
    sys.exit(main())
