"""The figure of the surface form's definition (docs/surface_form.png).

    python tools/surface_figure.py [--out docs/surface_form.png]

A few 0.05 m cells, a wall face exactly on a cell edge and a slanted face clipping cell
corners, a handful of occupied cells: each occupied cell's square grown by tau (dashed), the
cells touching a surface (grey) and not (red), the stretches of surface covered (green) and
missed (yellow), scored by metrics.classify_surface.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/surface_form.png")
    ap.add_argument("--tau", type=float, default=None, help="default: the metric's default tau")
    args = ap.parse_args(argv)
    from metrics.surface import DEFAULT_TAU_M
    if args.tau is None:
        args.tau = DEFAULT_TAU_M
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyBboxPatch

    from metrics.plot import plot_surface
    from metrics.surface import classify_surface
    from worlds.grid import Grid

    res = 0.05
    prob = np.zeros((6, 8))
    occupied = [(0, 2), (1, 2), (2, 2), (3, 3), (4, 2),        # along the face x = 0.15
                (1, 5), (2, 5), (3, 6), (0, 6),                # along the slanted face
                (5, 7), (2, 4)]                                # one cell off, one far off
    for r, c in occupied:
        prob[r, c] = 1.0
    grid = Grid(prob, res, np.array([0.0, 0.0, 0.0]))
    segments = np.array([[0.15, 0.0, 0.15, 0.30],             # on the edge of columns 2 and 3
                         [0.26, 0.0, 0.40, 0.30]])            # slanted
    sc = classify_surface(grid, segments, (0.0, 0.0, 0.0), args.tau)
    fig = Figure(figsize=(7.5, 4.2), dpi=120)
    ax = fig.add_subplot(1, 1, 1)
    for k in range(9):
        ax.axvline(k * res, color="0.85", lw=0.6, zorder=0)
    for k in range(7):
        ax.axhline(k * res, color="0.85", lw=0.6, zorder=0)
    for r, c in occupied:
        ax.add_patch(FancyBboxPatch((c * res, r * res), res, res,
                                    boxstyle=f"round,pad={args.tau},rounding_size={args.tau}",
                                    fill=False, ls="--", lw=0.6, ec="0.4"))
    plot_surface(ax, sc, "the surface form: a cell is right when its square grown by tau "
                         "(dashed) touches a surface")
    ax.set_xlim(-0.03, 0.43)
    ax.set_ylim(-0.03, 0.33)
    fig.tight_layout()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    print(out, sc.counts)
    return 0


if __name__ == "__main__":
    sys.exit(main())
