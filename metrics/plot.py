"""Drawing of the TP/FP/FN overlay in the reference study's colours.

TP green, FP red, FN yellow; cells the estimate knows as free light grey, everything else
(unknown in the estimate) white. A legend with the counts, a scale bar and a title.
"""
from __future__ import annotations

import os

import numpy as np

from worlds.grid import FREE_THRESH

__all__ = ["COLOURS", "overlay_rgb", "plot_overlay", "save_overlay"]

COLOURS = {"tp": (0.10, 0.70, 0.15), "fp": (0.90, 0.10, 0.10), "fn": (1.00, 0.85, 0.00),
           "free": (0.86, 0.86, 0.86), "unknown": (1.0, 1.0, 1.0)}


def overlay_rgb(overlay) -> np.ndarray:
    """(rows, cols, 3) float RGB image of an Overlay (row 0 at the bottom)."""
    rgb = np.empty(overlay.grid.shape + (3,))
    rgb[:] = COLOURS["unknown"]
    with np.errstate(invalid="ignore"):
        rgb[overlay.est_prob <= FREE_THRESH] = COLOURS["free"]
    c = overlay.classes
    rgb[c.fn] = COLOURS["fn"]
    rgb[c.fp] = COLOURS["fp"]
    rgb[c.tp] = COLOURS["tp"]
    return rgb


def _nice_length(span_m: float) -> float:
    target = span_m / 5.0
    for v in (0.1, 0.2, 0.25, 0.5, 1, 2, 5, 10, 20, 50, 100, 200, 500):
        if v >= target:
            return float(v)
    return float(10 ** np.ceil(np.log10(target)))


def plot_overlay(ax, overlay, title: str = "") -> None:
    """Draw an Overlay on matplotlib axes `ax`, in metres (the grid's yaw is not drawn)."""
    from matplotlib.patches import Patch, Rectangle

    g = overlay.grid
    left, right, bottom, top = g.extent()
    ax.imshow(overlay_rgb(overlay), origin="lower", extent=(left, right, bottom, top),
              interpolation="nearest")
    counts = overlay.classes.counts
    handles = [Patch(color=COLOURS["tp"], label=f"TP {counts['tp']}"),
               Patch(color=COLOURS["fp"], label=f"FP {counts['fp']}"),
               Patch(color=COLOURS["fn"], label=f"FN {counts['fn']}"),
               Patch(facecolor=COLOURS["free"], edgecolor="0.5", label="free (estimate)")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              frameon=False)
    length = _nice_length(right - left)
    x0 = left + 0.05 * (right - left)
    y0 = bottom + 0.04 * (top - bottom)
    ax.add_patch(Rectangle((x0, y0), length, 0.008 * (top - bottom), color="black"))
    ax.text(x0 + length / 2, y0 + 0.015 * (top - bottom), f"{length:g} m", ha="center",
            va="bottom", fontsize=8, bbox={"facecolor": "white", "edgecolor": "none", "pad": 1})
    sub = (f"P {counts['precision']:.3f}  S {counts['sensitivity']:.3f}  F1 {counts['f1']:.3f}"
           + (f"  (tolerance {counts['tolerance']})" if counts["tolerance"] else ""))
    ax.set_title(f"{title}\n{sub}" if title else sub, fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")


def save_overlay(overlay, path: str | os.PathLike, title: str = "") -> None:
    """Write the overlay picture as a PNG (no pyplot global state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    g = overlay.grid
    aspect = g.rows / max(g.cols, 1)
    fig = Figure(figsize=(7.0, max(3.0, min(9.0, 5.0 * aspect + 1.0))), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    plot_overlay(ax, overlay, title)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path)
