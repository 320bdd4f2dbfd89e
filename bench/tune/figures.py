"""A tune's figures: the objective over trials with the best so far, and each searched field
against the objective (matplotlib, written as PNG)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["objective_figure", "params_figure"]


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _points(trials):
    """(number, value, pruned) of each trial with a value: a complete trial's value, a pruned
    one's last reported mean."""
    out = []
    for t in trials:
        if t.state.name == "COMPLETE" and t.value is not None:
            out.append((t.number, t.value, False))
        elif t.state.name == "PRUNED" and t.intermediate_values:
            out.append((t.number, t.intermediate_values[max(t.intermediate_values)], True))
    return out


def objective_figure(trials, objective, path: Path) -> None:
    """The objective of every trial (pruned ones at their last reported mean, hollow) and the
    best complete trial so far."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    pts = _points(trials)
    done = [(n, v) for n, v, p in pts if not p]
    cut = [(n, v) for n, v, p in pts if p]
    if done:
        ax.plot(*zip(*done), "o", color="tab:blue", label="complete")
        best, line = None, []
        for n, v in done:
            best = v if best is None or objective.better(v, best) else best
            line.append((n, best))
        ax.step(*zip(*line), where="post", color="tab:orange", label="best so far")
    if cut:
        ax.plot(*zip(*cut), "o", mfc="none", color="tab:gray", label="pruned (mean so far)")
    ax.set_xlabel("trial")
    ax.set_ylabel(objective.label)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def params_figure(trials, space, objective, path: Path) -> None:
    """One panel per searched field: its value in each complete trial against the objective."""
    plt = _plt()
    n = len(space.params)
    cols = min(3, n)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 2.8 * rows), squeeze=False)
    done = [t for t in trials if t.state.name == "COMPLETE" and t.value is not None]
    for ax, p in zip(axes.flat, space.params):
        xs = [t.params[p.path] for t in done if p.path in t.params]
        ys = [t.value for t in done if p.path in t.params]
        if p.kind == "choice":
            labels = [str(c) for c in p.choices]
            xs = [labels.index(str(x)) for x in xs]
            ax.set_xticks(range(len(labels)), labels, fontsize=7)
        elif p.log:
            from matplotlib.ticker import NullFormatter
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())   # minor labels overlap
        ax.tick_params(labelsize=7)
        ax.plot(xs, ys, "o", ms=4)
        ax.set_title(p.path.split(".")[-1], fontsize=8)
        ax.set_ylabel(objective.label, fontsize=7)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
