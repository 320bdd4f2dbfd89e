"""Drawing of sensor logs (matplotlib is imported here only)."""
from __future__ import annotations

from pathlib import Path


from sim.logs import SensorLog

__all__ = ["draw_world", "draw_paths", "plot_log"]


def draw_world(ax, world) -> None:
    """Fill the world's walls and obstacles (World.solid) on `ax`."""
    from shapely.geometry import MultiPolygon
    solid = world.solid
    polys = solid.geoms if isinstance(solid, MultiPolygon) else [solid]
    for poly in polys:
        if poly.is_empty:
            continue
        ax.fill(*poly.exterior.xy, color="0.3", lw=0)
        for ring in poly.interiors:
            ax.fill(*ring.xy, color="white", lw=0)


def draw_paths(ax, log: SensorLog) -> None:
    """True path (gt_pose) and odometry path (odom_pose) of `log` on `ax`."""
    if log.has_ground_truth:
        ax.plot(log.gt_pose[:, 0], log.gt_pose[:, 1], color="tab:green", lw=1.2, label="true")
    if log.has_odometry:
        ax.plot(log.odom_pose[:, 0], log.odom_pose[:, 1], color="tab:red", lw=1.0, ls="--",
                label="odometry")
    s = log.start_pose
    ax.plot([s[0]], [s[1]], "ko", ms=4, label="start")


def plot_log(log: SensorLog, world, path: str | Path) -> None:
    """Write a PNG of the log's paths over `world` (None: paths only)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 7))
    if world is not None:
        draw_world(ax, world)
    draw_paths(ax, log)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    d = log.meta.get("odometry_drift")
    title = f"{log.meta.get('world', '')} seed {log.meta.get('seed', '')} " \
            f"{log.meta.get('noise', {}).get('name', '')}"
    if d:
        title += f"\nodometry drift {100 * d['segment_drift']:.1f} % per {d['segment']:.0f} m, " \
                 f"end error {d['end_error']:.2f} m over {d['distance']:.1f} m"
    ax.set_title(title, fontsize=9)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
