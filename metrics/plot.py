"""Drawing of the TP/FP/FN overlay in the reference study's colours.

TP green, FP red, FN yellow; cells the estimate knows as free light grey, everything else
(unknown in the estimate) white. A legend with the counts, a scale bar and a title.
"""
from __future__ import annotations

import io
import os

import numpy as np

from worlds.grid import FREE_THRESH
from worlds.yamlio import atomic_write_bytes

__all__ = ["COLOURS", "PICTURE_FORMATS", "overlay_rgb", "plot_overlay", "save_overlay",
           "save_figure", "plot_surface", "save_surface"]

# the file types save_overlay and save_surface write (by the path's suffix)
PICTURE_FORMATS = ("png", "pdf", "svg")

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
    _titles(ax, title, sub)


def _titles(ax, title: str, sub: str) -> None:
    """Title (and the scores under it), axis labels in metres, equal aspect."""
    ax.set_title(f"{title}\n{sub}" if title else sub, fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")


def save_overlay(overlay, path: str | os.PathLike, title: str = "") -> None:
    """Write the overlay picture, as PNG, PDF or SVG by the suffix (no pyplot global state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    g = overlay.grid
    aspect = g.rows / max(g.cols, 1)
    fig = Figure(figsize=(7.0, max(3.0, min(9.0, 5.0 * aspect + 1.0))), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    plot_overlay(ax, overlay, title)
    fig.tight_layout()
    save_figure(fig, path)


def plot_surface(ax, surface, title: str = "") -> None:
    """Draw a SurfaceClassification on `ax` in the world frame: the true surfaces as lines,
    covered stretches green and missed ones yellow; occupied cells grey (true positive) or
    red (false positive)."""
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.patches import Patch

    from slam.pose import transform_points

    g = surface.grid
    res = g.resolution
    for mask, colour in ((surface.tp, "0.55"), (~surface.tp, COLOURS["fp"])):
        corners = [g.cell_to_world(surface.rows[mask], surface.cols[mask]) + off
                   for off in ((-res / 2, -res / 2), (res / 2, -res / 2), (res / 2, res / 2),
                               (-res / 2, res / 2))]
        quads = np.stack([transform_points(surface.pose, c) for c in corners], axis=1)
        ax.add_collection(PolyCollection(quads, facecolors=colour, edgecolors="none"))
    segs = surface.segments
    ax.add_collection(LineCollection(segs.reshape(-1, 2, 2), colors=[COLOURS["fn"]],
                                     linewidths=1.6))
    iv = surface.intervals
    if len(iv):
        s = segs[iv[:, 0].astype(int)]
        a = s[:, :2] + iv[:, 1:2] * (s[:, 2:] - s[:, :2])
        b = s[:, :2] + iv[:, 2:3] * (s[:, 2:] - s[:, :2])
        ax.add_collection(LineCollection(np.stack([a, b], axis=1), colors=[COLOURS["tp"]],
                                         linewidths=1.6))
    counts = surface.counts
    missed = counts["surface_length_m"] - counts["surface_covered_m"]
    covered = counts["surface_covered_m"]
    handles = [Patch(color=COLOURS["tp"], label=f"surface covered {covered:.2f} m"),
               Patch(color=COLOURS["fn"], label=f"surface missed {missed:.2f} m"),
               Patch(color="0.55", label=f"cell touching a surface {counts['surface_tp']}"),
               Patch(color=COLOURS["fp"], label=f"false cell {counts['surface_fp']}")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              frameon=False)
    pts = np.vstack([segs[:, :2], segs[:, 2:]])
    lo, hi = pts.min(axis=0) - 0.3, pts.max(axis=0) + 0.3
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    sub = (f"surface form: P {counts['surface_precision']:.3f}  "
           f"S {counts['surface_sensitivity']:.3f}  F1 {counts['surface_f1']:.3f}  "
           f"(tau {counts['surface_tau_m']:g} m)")
    _titles(ax, title, sub)


def save_surface(surface, path: str | os.PathLike, title: str = "") -> None:
    """Write the surface-form picture (plot_surface), as PNG, PDF or SVG by the suffix."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    segs = surface.segments
    span = np.ptp(np.vstack([segs[:, :2], segs[:, 2:]]), axis=0) + 0.6
    height = max(3.0, min(9.0, 5.5 * span[1] / max(span[0], 1e-9) + 1.0))
    fig = Figure(figsize=(7.5, height), dpi=120)
    FigureCanvasAgg(fig)
    plot_surface(fig.add_subplot(1, 1, 1), surface, title)
    fig.tight_layout()
    save_figure(fig, path, bbox_inches="tight")   # the legend sits outside the axes


def save_figure(fig, path, **savefig_kw) -> None:
    """Write a matplotlib figure atomically (a unique temporary file, then a rename): a kill
    never leaves half a picture. The format follows the file's suffix."""
    buf = io.BytesIO()
    fmt = os.path.splitext(str(path))[1].lstrip(".").lower() or "png"
    fig.savefig(buf, format=fmt, **savefig_kw)
    atomic_write_bytes(path, buf.getvalue())
