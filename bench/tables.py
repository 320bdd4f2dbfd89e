"""summary.md and summary.csv from the rows of results.json, in the reference study's layout.

Table 1 of the study: rows = worlds, columns = algorithms, cells "mean ± std" of ADNN in
cells. Table 2: per world and algorithm, precision and sensitivity "mean ± std". The main
precision / sensitivity / F1 are the surface form's (metrics.surface: the walls' surfaces
within tau) in every world whose successful rows all have it (simulated worlds); in a world
whose truth is only a raster they are the study's exact-cell rule, marked "(cell)". The
study's cell rule stands beside in its own tables and beside the study's published numbers.
We add the cell rule at a tolerance of 1 cell, ATE, RPE and the real-time factor. Columns
follow algo_order; an algorithm whose class uses the ground truth (the oracle: maps with the
true poses) is the last column: the ceiling a SLAM could reach with perfect poses. The tables
and the CSV columns are the columns of metrics.registry: a column with a section joins that
table, every other one with a value gets a table under "More metrics".
Statistics use the rows with status "ok"; std is the sample standard deviation (ddof=1,
0 for a single repeat); failures are counted in their own table.
A run with several noise draws per world (a suite) also gets, per world, the mean and std
over the draws (each draw first averaged over its repeats), the ceiling's score and each
algorithm's gap to it, and an overall table: the mean over worlds. Whenever the study's worlds
are in the run, the study's published numbers (bench.study) stand beside each algorithm of a
family the study ran (the class's `family`).
"""
from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from metrics import registry
from metrics.registry import Column
from slam import registry as algo_registry
from worlds.yamlio import atomic_write_text

__all__ = ["aggregate", "summary_markdown", "summary_csv", "write_tables", "mean_std",
           "algo_order", "world_order", "over_draws", "draw_means", "surface_worlds", "main_key",
           "surface_label", "is_ceiling"]


def mean_std(values) -> tuple[float, float, int]:
    """(mean, sample std, n) of the finite values; NaNs when there are none."""
    v = np.asarray([x for x in values if x is not None], dtype=np.float64)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return float("nan"), float("nan"), 0
    return float(v.mean()), float(v.std(ddof=1)) if len(v) > 1 else 0.0, len(v)


def is_ceiling(algo: str) -> bool:
    """Whether `algo` maps with the true poses (its class's uses_ground_truth: the oracle): the
    ceiling the others are read against. False for a name no class is registered under."""
    return bool(getattr(algo_registry.find(algo), "uses_ground_truth", False))


def algo_order(algos) -> list[str]:
    """The shipped algorithms in the registry's order, then the others (plugins, maps scored
    elsewhere) alphabetically; the ceilings (is_ceiling) last, in the same order."""
    algos = list(dict.fromkeys(algos))
    shipped = [a for a in algo_registry.BUILTIN if a in algos]
    ordered = shipped + sorted(a for a in algos if a not in shipped)
    return ([a for a in ordered if not is_ceiling(a)] + [a for a in ordered if is_ceiling(a)])


def world_order(rows: list[dict], run: dict | None = None) -> list[str]:
    """Worlds in the order the run named them (run.json), then any others as they appear."""
    named = list((run or {}).get("worlds", {}))
    seen = set(r["world"] for r in rows)
    return [w for w in named if w in seen] + [w for w in dict.fromkeys(r["world"] for r in rows)
                                              if w not in named]


def _fallbacks() -> dict[str, str]:
    """cell-form key -> the surface-form key shown in its place (the registry's fallbacks)."""
    return {c.fallback: c.key for c in registry.columns() if c.fallback}


def surface_worlds(rows: list[dict]) -> set[str]:
    """The worlds whose every successful row has the surface form (simulated worlds): their
    main precision / sensitivity / F1 are the surface form's; the other worlds' (a truth that
    is only a raster, rows scored before the surface form) are the study's cell rule."""
    keys = list(_fallbacks().values())
    ok: dict[str, list[dict]] = {}
    for r in rows:
        if r.get("status") == "ok":
            ok.setdefault(r["world"], []).append(r)
    return {w for w, rs in ok.items() if all(r.get(k) is not None for r in rs for k in keys)}


def main_key(key: str, world: str, surface: set[str]) -> str:
    """The key shown as the main `key` ("precision", "sensitivity", "f1") of `world`: the
    surface form's in the `surface` worlds (surface_worlds), else `key` (the cell rule)."""
    return _fallbacks().get(key, key) if world in surface else key


def _tau_text(rows: list[dict]) -> str:
    """"tau = 0.005 m": the surface form's tolerance in the rows (several if they differ;
    metrics.surface.DEFAULT_TAU_M if no row has one)."""
    taus = sorted({float(r["surface_tau_m"]) for r in rows
                   if r.get("status") == "ok" and r.get("surface_tau_m") is not None})
    if not taus:
        from metrics.surface import DEFAULT_TAU_M
        taus = [DEFAULT_TAU_M]
    return "tau = " + ", ".join(f"{t:g}" for t in taus) + " m"


def surface_label(rows: list[dict]) -> str:
    """"surface, tau = 0.005 m": the surface form and the tau of the rows."""
    return f"surface, {_tau_text(rows)}"


def _form_note(rows: list[dict], worlds) -> list[str]:
    """The line under a table of the main precision and sensitivity naming their form."""
    surface = surface_worlds(rows)
    cell = [w for w in worlds if w not in surface]
    text = (f"Main form: {surface_label(rows)} (metrics.surface: an occupied cell is right when "
            "it lies within tau of a wall surface; sensitivity is the share of the surfaces' "
            "length within tau of an occupied cell).")
    if cell:
        text += (f" Worlds without the surfaces ({', '.join(cell)}: a truth that is only a "
                 "raster) show the study's cell rule, marked (cell).")
    return [text, ""]


def aggregate(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """(world, algo) -> {"n", "failed", "errors", key: (mean, std, n) of every registry
    column}."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["world"], r["algo"]), []).append(r)
    out = {}
    for key, rs in groups.items():
        ok = [r for r in rs if r.get("status") == "ok"]
        agg = {"n": len(rs), "failed": len(rs) - len(ok),
               "errors": sorted({str(r.get("error")) for r in rs if r.get("status") != "ok"})}
        for c in registry.columns():
            agg[c.key] = mean_std(r.get(c.key) for r in ok)
        out[key] = agg
    return out


def draw_means(rows: list[dict], metric: str) -> dict[tuple[str, str], dict[int, float]]:
    """(world, algo) -> {draw: mean of `metric` over the draw's ok rows}; draws with no ok
    row are absent."""
    per_draw: dict[tuple[str, str, int], list] = {}
    for r in rows:
        if r.get("status") == "ok":
            per_draw.setdefault((r["world"], r["algo"], int(r.get("draw", 0))), []).append(r.get(metric))
    out: dict[tuple[str, str], dict[int, float]] = {}
    for (w, a, d), vals in sorted(per_draw.items()):
        m, _, n = mean_std(vals)
        if n:
            out.setdefault((w, a), {})[d] = m
    return out


def over_draws(rows: list[dict], metric: str) -> dict[tuple[str, str], tuple[float, float, int]]:
    """(world, algo) -> (mean, sample std, n) over noise draws of `metric`: each draw's ok rows
    averaged first, draws with no ok row left out."""
    return {k: mean_std(v.values()) for k, v in draw_means(rows, metric).items()}


def _gap(ceiling: dict[int, float] | None, mine: dict[int, float] | None) -> float | None:
    """Mean over the draws both have of ceiling - mine (None if they share no draw)."""
    common = sorted(set(ceiling or {}) & set(mine or {}))
    return float(np.mean([ceiling[d] - mine[d] for d in common])) if common else None


_PS = (("precision", "P"), ("sensitivity", "S"))


def _draw_sections(worlds, algos, rows: list[dict], agg: dict) -> list[str]:
    """Per-world mean ± std over draws, the gap to the ceiling, and the mean over worlds;
    agg: aggregate(rows), for the row and failure counts."""
    surface = surface_worlds(rows)
    forms = _fallbacks()
    ps_keys = {k for m in ("precision", "sensitivity") for k in (m, forms.get(m, m))}
    per_draw = {m: draw_means(rows, m) for m in (*sorted(ps_keys), "adnn_cells", "ate_m")}
    stats = {m: {k: mean_std(v.values()) for k, v in d.items()} for m, d in per_draw.items()}
    gaps, gap_lines = _gap_section(worlds, algos, per_draw, surface)
    return (_over_draws_section(worlds, algos, rows, agg, stats, surface) + gap_lines
            + _overall_section(worlds, algos, rows, agg, stats, gaps, surface))


def _over_draws_section(worlds, algos, rows, agg, stats, surface) -> list[str]:
    """Precision and sensitivity per world, mean ± std over the draws' means."""
    head = [f"{_head(a)} {lab}" for a in algos for _, lab in _PS]
    out = [f"## Across noise draws: precision (P) and sensitivity (S) ({surface_label(rows)}), "
           "mean ± std over draws", "", *_form_note(rows, worlds),
           "| world | " + " | ".join(head) + " |", "|---" * (len(head) + 1) + "|"]
    for w in worlds:
        cells = []
        for a in algos:
            for m, _ in _PS:
                c = _cell(stats[main_key(m, w, surface)].get((w, a), (math.nan, math.nan, 0)), 3)
                if c != "–" and w not in surface:
                    c += " (cell)"
                g = agg.get((w, a))
                if m == "precision" and g and g["failed"]:
                    c += f" ({g['failed']}/{g['n']} failed)"
                cells.append(c)
        out.append(f"| {w} | " + " | ".join(cells) + " |")
    return out + [""]


def _gap_section(worlds, algos, per_draw, surface) -> tuple[dict, list[str]]:
    """({(world, algo, metric): ceiling - algo}, the table of those gaps): the first ceiling
    of the run (is_ceiling) against every other algorithm; nothing without a ceiling."""
    ceilings = [a for a in algos if is_ceiling(a)]
    slams = [a for a in algos if not is_ceiling(a)]
    if not ceilings or not slams:
        return {}, []
    ceiling = ceilings[0]
    head = [f"{a} {lab}" for a in slams for _, lab in _PS]
    out = [f"## Gap to the ceiling: {ceiling} − algorithm, mean over the draws both finished "
           "(lower is better)", "",
           "| world | " + " | ".join(head) + " |", "|---" * (len(head) + 1) + "|"]
    gaps: dict[tuple[str, str, str], float] = {}
    for w in worlds:
        cells = []
        for a in slams:
            for m, _ in _PS:
                k = main_key(m, w, surface)
                g = _gap(per_draw[k].get((w, ceiling)), per_draw[k].get((w, a)))
                if g is not None:
                    gaps[(w, a, m)] = g
                cells.append("–" if g is None else f"{g:+.3f}")
        out.append(f"| {w} | " + " | ".join(cells) + " |")
    return gaps, out + [""]


def _overall_section(worlds, algos, rows, agg, stats, gaps, surface) -> list[str]:
    """One line per algorithm: the mean over worlds of its per-world means and gaps."""
    out = ["## Overall: mean over worlds of the per-world means", "",
           "Worlds where an algorithm has no successful draw are left out of its means "
           f"and counted under 'worlds'. P and S: the main form ({surface_label(rows)}; the "
           "study's cell rule in worlds marked (cell) above).", "",
           "| algorithm | worlds | P | S | gap P | gap S | ADNN (cells) | ATE (m) | failed rows |",
           "|---|---|---|---|---|---|---|---|---|"]
    for a in algos:
        def avg(metric, fmt):
            keys = {w: main_key(metric, w, surface) for w in worlds}
            vals = [stats[keys[w]][(w, a)][0] for w in worlds if (w, a) in stats[keys[w]]]
            return (fmt.format(float(np.mean(vals))) if vals else "–"), len(vals)

        def mean_gap(metric):
            g = [gaps[(w, a, metric)] for w in worlds if (w, a, metric) in gaps]
            return f"{np.mean(g):+.3f}" if g else "–"
        p, n_w = avg("precision", "{:.3f}")
        sens, _ = avg("sensitivity", "{:.3f}")
        adnn, _ = avg("adnn_cells", "{:.2f}")
        ate, _ = avg("ate_m", "{:.3f}")
        n_fail = sum(agg[(w, a)]["failed"] for w in worlds if (w, a) in agg)
        n_all = sum(agg[(w, a)]["n"] for w in worlds if (w, a) in agg)
        out.append(f"| {_head(a)} | {n_w}/{len(worlds)} | {p} | {sens} | {mean_gap('precision')} | "
                   f"{mean_gap('sensitivity')} | {adnn} | {ate} | {n_fail}/{n_all} |")
    return out + [""]


def _study_sections(worlds, algos, agg, rows: list[dict]) -> list[str]:
    """Our algorithms beside the study's algorithm of the family each declares (bench.study.
    family_of), on the study worlds: the study's cell rule (the form of its numbers) beside its
    numbers, our main (surface) form after them."""
    from bench.study import STUDY, STUDY_WORLDS, family_of
    shown = [w for w in STUDY_WORLDS if w in worlds]
    family = {a: family_of(a) for a in algos}
    ours = [a for a in algos if family[a]]
    if not shown or not ours:
        return []
    surface = surface_worlds(rows)
    form = surface_label(rows)
    out = ["## Beside the reference study (Zi et al., Tables 1-2)", "",
           "The study ran Gmapping, Hector and Cartographer in ROS on one Gazebo log per world, "
           "10 runs each; its numbers stand beside our algorithm of the same family. Ours: mean "
           "± std over every successful row of this run (all draws and repeats), scored with "
           f"the study's cell rule as the study's numbers are, then in the surface form ({form}).",
           ""]
    for title, metrics, dec, forms in (
            ("Precision / sensitivity", ("precision", "sensitivity"), 3,
             (("study's cell rule", False), (form, True))),
            ("ADNN (cells)", ("adnn_cells",), 2, (("", False),))):
        head = []
        for a in ours:
            head += [f"{family[a]} (study)"] + [f"{a} ({f})" if f else a for f, _ in forms]
        out += [f"### {title}", "", "| world | " + " | ".join(head) + " |",
                "|---" * (len(head) + 1) + "|"]
        for w in shown:
            cells = []
            for a in ours:
                theirs = STUDY[family[a]]
                cells.append(" / ".join(f"{theirs[m][w][0]:.{min(dec, 2)}f}" for m in metrics))
                g = agg.get((w, a))
                for _, main in forms:
                    if not g or (main and w not in surface):
                        cells.append("–")
                        continue
                    keys = [main_key(m, w, surface) if main else m for m in metrics]
                    cells.append(" / ".join(_cell(g[k], dec) for k in keys))
            out.append(f"| {w} | " + " | ".join(cells) + " |")
        out.append("")
    return out


def _cell(stat, decimals: int) -> str:
    mean, std, n = stat
    if n == 0 or not math.isfinite(mean):
        return "–"
    return f"{mean:.{decimals}f} ± {std:.{decimals}f}"


def _head(algo: str) -> str:
    return f"{algo} (ceiling)" if is_ceiling(algo) else algo


def _table(worlds, algos, agg, cols: list[Column], surface: set[str]) -> str:
    """Markdown table: one row per world, one column per algorithm x registry column; a column
    with a fallback shows the fallback key, marked (cell), in worlds not in `surface`."""
    multi = len(cols) > 1
    heads = [f"{_head(a)} {c.short}" if multi else _head(a) for a in algos for c in cols]
    lines = ["| world | " + " | ".join(heads) + " |", "|---" * (len(heads) + 1) + "|"]
    for w in worlds:
        cells = []
        for a in algos:
            g = agg.get((w, a))
            for c in cols:
                key = c.fallback if c.fallback and w not in surface else c.key
                cell = _cell(g[key], c.decimals) if g else "–"
                if key != c.key and cell != "–":
                    cell += " (cell)"
                if g and g["failed"] and c is cols[0]:
                    cell += f" ({g['failed']}/{g['n']} failed)"
                cells.append(cell)
        lines.append(f"| {w} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _metric_sections(worlds, algos, agg, rows: list[dict]) -> list[str]:
    """One table per registered section, then one per other column that has a value."""
    cols = registry.columns()
    surface = surface_worlds(rows)
    out = []
    for sec in registry.sections():
        mine = [c for c in cols if c.section == sec.name]
        if mine:
            note = _form_note(rows, worlds) if any(c.fallback for c in mine) else []
            out += [f"## {sec.title}", "", *note, _table(worlds, algos, agg, mine, surface), ""]
    rest = [c for c in cols if not c.section and any(
        g[k][2] for g in agg.values() for k in (c.key, c.fallback) if k)]
    if rest:
        out += ["## More metrics, mean ± std", ""]
        for c in rest:
            better = {True: " (higher is better)", False: " (lower is better)"}.get(
                c.higher_is_better, "")
            label = f"{c.label}, {_tau_text(rows)}" if c.fallback else c.label
            out += [f"### {label}{better}", "", _table(worlds, algos, agg, [c], surface), ""]
    return out


def summary_markdown(rows: list[dict], run: dict | None = None,
                     figures: dict[str, str] | None = None) -> str:
    """The text of summary.md (see the module docstring); figures: caption -> relative path."""
    worlds = world_order(rows, run)
    algos = algo_order(r["algo"] for r in rows)
    agg = aggregate(rows)
    spec = (run or {}).get("spec", {})
    n_ok = sum(r.get("status") == "ok" for r in rows)
    out = ["# Benchmark summary", ""]
    draws = int(spec.get("draws", 1) or 1)
    if spec:
        suite = f"Suite: {spec['suite']}. " if spec.get("suite") else ""
        drawn = f"Noise draws per world: {draws} (log seeds {spec.get('seed')}.." \
                f"{spec.get('seed', 0) + draws - 1}). " if draws > 1 else ""
        out.append(f"{suite}Worlds: {', '.join(worlds)}. Algorithms: {', '.join(algos)}. {drawn}"
                   f"Repeats: {spec.get('repeats')}{' per draw' if draws > 1 else ''} (vary "
                   f"{spec.get('vary')}, base seed {spec.get('seed')}, noise {spec.get('noise')}).")
    vers = (run or {}).get("versions")
    if vers:
        out.append("Versions: " + ", ".join(f"{k} {v}" for k, v in vers.items()) + ".")
    ceilings = [a for a in algos if is_ceiling(a)]
    ceiling = (f" The {', '.join(ceilings)} map{'' if len(ceilings) > 1 else 's'} with the true "
               "poses: the ceiling." if ceilings else "")
    outside = sorted({r["algo"] for r in rows if r.get("source") == "outside"})
    if outside:
        out.append(f"Scored from maps made elsewhere (`bench add`): {', '.join(outside)}.")
    out += [f"Rows: {len(rows)} ({len(rows) - n_ok} failed). Cells: mean ± std over the repeats "
            f"that succeeded (sample std).{ceiling}", ""]
    if draws > 1 or any(int(r.get("draw", 0)) > 0 for r in rows):
        out += _draw_sections(worlds, algos, rows, agg)
    out += _study_sections(worlds, algos, agg, rows)
    out += _metric_sections(worlds, algos, agg, rows)
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
    keys = [c.key for c in registry.columns()]
    w.writerow(["world", "algo", "n", "failed"] +
               [f"{m}_{s}" for m in keys for s in ("mean", "std")])
    for world in worlds:
        for algo in algos:
            g = agg.get((world, algo))
            if not g:
                continue
            vals = []
            for m in keys:
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
