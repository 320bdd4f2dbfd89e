"""A tune's report: DIR/summary.md (defaults against the best config on the dev and hold-out
suites, with the spread over noise draws; the best values; every trial) and DIR/figures/
(the objective over trials with the best so far; each searched field against the objective)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from worlds.yamlio import atomic_write_text
from bench.tune.objective import Objective, excluded_rows, get_objective, per_draw, per_world
from bench.tune.space import load_space

__all__ = ["write_tune_report", "compare_runs"]


def _rows(folder: Path) -> list[dict] | None:
    from bench.results import RESULTS_NAME, read_rows
    path = folder / RESULTS_NAME
    return read_rows(path) if path.is_file() else None


def compare_runs(objective: Objective, base: list[dict], other: list[dict],
                 excluded: dict) -> dict:
    """Defaults (`base`) against a tuned config (`other`) on the same logs: each one's mean,
    the per-draw means, the per-draw difference (other - base) with its mean and standard
    deviation over draws, in how many worlds `other` is better, and how many of `other`'s runs
    failed where the defaults did not (they are in no mean: the table says so)."""
    a, b = per_draw(objective, base, excluded), per_draw(objective, other, excluded)
    draws = sorted(set(a) & set(b))
    diff = np.array([b[d] - a[d] for d in draws])
    wa, wb = per_world(objective, base, excluded), per_world(objective, other, excluded)
    worlds = sorted(set(wa) & set(wb))
    better = sum(objective.better(wb[w], wa[w]) for w in worlds)
    return {"base": float(np.mean([a[d] for d in draws])) if draws else None,
            "other": float(np.mean([b[d] for d in draws])) if draws else None,
            "draws": draws, "base_draws": [a[d] for d in draws],
            "other_draws": [b[d] for d in draws],
            "diff_mean": float(diff.mean()) if draws else None,
            "diff_std": float(diff.std(ddof=1)) if len(draws) > 1 else None,
            "better_worlds": better, "worlds": len(worlds),
            "failed": sorted(f"{r['world']} draw {int(r.get('draw') or 0)}: {r.get('error')}"
                             for r in other if r.get("status") != "ok"
                             and (r["world"], int(r.get("draw") or 0)) not in excluded)}


def _fmt(v, digits: int = 4) -> str:
    return "–" if v is None else f"{v:.{digits}f}"


def _comparison_table(objective: Objective, title: str, cmp: dict) -> list[str]:
    sign = "higher is better" if objective.direction == "maximize" else "lower is better"
    lines = [f"### {title}", "",
             f"{objective.label}, {sign}; draws {', '.join(map(str, cmp['draws']))}.", "",
             "| config | mean | per draw |", "|---|---|---|",
             f"| defaults | {_fmt(cmp['base'])} | {', '.join(_fmt(v) for v in cmp['base_draws'])} |",
             f"| best | {_fmt(cmp['other'])} | {', '.join(_fmt(v) for v in cmp['other_draws'])} |",
             ""]
    spread = "" if cmp["diff_std"] is None else f" ± {cmp['diff_std']:.4f} (std over draws)"
    lines.append(f"best - defaults: {_fmt(cmp['diff_mean'])}{spread}; the best config is better "
                 f"on {cmp['better_worlds']} of {cmp['worlds']} worlds.")
    if cmp["failed"]:
        lines += ["", f"**{len(cmp['failed'])} runs of the best config failed** where the "
                  "defaults did not; they are in no mean above:", ""]
        lines += [f"- {f}" for f in cmp["failed"]]
    return lines + [""]


def write_tune_report(out_dir: str | Path, figures: bool = True) -> Path:
    """Write DIR/summary.md (and DIR/figures/ unless figures=False) of the tune in `out_dir`;
    the summary's path."""
    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend
    from bench.tune.search import BEST_NAME, JOURNAL_NAME, STUDY_NAME, read_tune
    out_dir = Path(out_dir)
    spec = read_tune(out_dir)
    objective = get_objective(spec.objective)
    space = load_space(spec.space or None, spec.algo)
    storage = JournalStorage(JournalFileBackend(str(out_dir / JOURNAL_NAME)))
    study = optuna.load_study(study_name=STUDY_NAME, storage=storage)
    trials = study.trials
    states = [t.state.name.lower() for t in trials]
    lines = [f"# bench tune: {spec.algo}", "",
             f"- dev suite: {spec.suite}; hold-out suite: {spec.holdout or 'none'}",
             f"- objective: {objective.label} ({objective.direction}); search space: "
             f"{spec.space or 'the shipped space of ' + spec.algo}; sampler TPE, seed {spec.seed}",
             f"- trials: {len(trials)} ({states.count('complete')} complete, "
             f"{states.count('pruned')} pruned, {states.count('fail')} failed)", ""]
    defaults = _rows(out_dir / "defaults") or []
    excluded = excluded_rows(defaults)
    if excluded:
        lines += ["Left out of every trial (failed under the defaults):", ""]
        lines += [f"- {w} draw {d}: {why}" for (w, d), why in sorted(excluded.items())] + [""]
    complete = [t for t in trials if t.value is not None and t.state.name == "COMPLETE"]
    best = study.best_trial if complete else None
    if best is not None:
        lines += [f"## Best: trial {best.number}, {objective.label} {best.value:.5g}", "",
                  f"Config: [{BEST_NAME}]({BEST_NAME}) (`--config {spec.algo}={BEST_NAME}`).", ""]
        lines += _values_table(spec.algo, space, best.params)
        best_rows = _rows(out_dir / best.user_attrs.get("run", "")) or []
        lines += _comparison_table(objective, "Dev suite (chosen on it)",
                                   compare_runs(objective, defaults, best_rows, excluded))
        hold_a = _rows(out_dir / "holdout" / "defaults")
        hold_b = _rows(out_dir / "holdout" / f"trial_{best.number:04d}")
        if hold_a is not None and hold_b is not None:
            hold_ex = excluded_rows(hold_a)
            lines += _comparison_table(objective, "Hold-out suite (not seen while choosing)",
                                       compare_runs(objective, hold_a, hold_b, hold_ex))
            if hold_ex:
                lines += [f"Left out on the hold-out suite: {len(hold_ex)} world draws that failed "
                          "under the defaults.", ""]
    else:
        lines += ["No trial completed.", ""]
    lines += _trials_table(space, trials)
    if figures and trials:
        from bench.tune.figures import objective_figure, params_figure
        fig_dir = out_dir / "figures"
        fig_dir.mkdir(exist_ok=True)
        objective_figure(trials, objective, fig_dir / "objective.png")
        params_figure(trials, space, objective, fig_dir / "params.png")
        lines += ["![objective over trials](figures/objective.png)", "",
                  "![each field against the objective](figures/params.png)", ""]
    md = out_dir / "summary.md"
    atomic_write_text(md, "\n".join(lines))
    atomic_write_text(out_dir / "summary.json", json.dumps(
        {"best_trial": None if best is None else best.number,
         "best_value": None if best is None else best.value,
         "best_params": None if best is None else best.params}, indent=1) + "\n")
    return md


def _values_table(algo: str, space, params: dict) -> list[str]:
    from bench.tune.space import field_defaults
    defaults = field_defaults(algo)
    lines = ["| field | default | best | searched |", "|---|---|---|---|"]
    for p in space.params:
        rng = (", ".join(map(str, p.choices)) if p.kind == "choice"
               else f"{p.low:g} – {p.high:g}{' (log)' if p.log else ''}")
        lines.append(f"| `{p.path}` | {_value(defaults.get(p.path))} | "
                     f"{_value(params.get(p.path))} | {rng} |")
    return lines + ["", "A default that the algorithm derives from the log (`slam run --explain`) "
                    "is shown as its class default; a tuned value replaces it on every log.", ""]


def _value(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _trials_table(space, trials) -> list[str]:
    head = "| trial | state | value | " + " | ".join(f"`{p.path.split('.')[-1]}`"
                                                    for p in space.params) + " |"
    lines = ["## Trials", "", "A pruned trial's value is its mean over the worlds it finished.", "",
             head, "|" + "---|" * (3 + len(space.params))]
    for t in trials:
        if t.state.name == "PRUNED":
            state = f"pruned at world {len(t.intermediate_values)}"
        elif t.state.name == "FAIL":
            state = f"failed: {str(t.user_attrs.get('failure', ''))[:60]}"
        else:
            state = t.state.name.lower()
        if t.user_attrs.get("defaults"):
            state += " (the defaults)"
        vals = " | ".join(_value(t.params.get(p.path, "–")) for p in space.params)
        lines.append(f"| {t.number} | {state} | {_fmt(t.value, 5)} | {vals} |")
    return lines + [""]
