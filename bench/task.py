"""What one worker does: run one SLAM on one log, check it, score its map and trajectory.

`execute(task, world, log_source, config, noise, vary)` never raises for a SLAM's own
failure: an exception or a diverged result (NaN pose, pose more than `DIVERGE_MARGIN_M`
outside the world's bounds) becomes a row with status "failed" and the message, so one bad
run is a recorded result, not a crashed benchmark. It returns (row, arrays): the row of
results.json and the map and trajectory arrays the report draws (the caller stores them).
`record_log` is the other worker job: record one sensor log. Each worker process warms
each algorithm up once on the first scans of the log (`warm_up`), so wall times and
real-time factors exclude numba compilation (the run's total time includes it).
"""
from __future__ import annotations

import platform
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from worlds.grid import Grid

__all__ = ["WorldInfo", "execute", "record_log", "versions", "DIVERGE_MARGIN_M", "TOLERANCES",
           "check_divergence", "new_row", "score_trajectory", "failure_fields"]

# a pose this far outside the world's solid geometry cannot be a working SLAM
DIVERGE_MARGIN_M = 2.0
# grid-portion tolerances (cells) scored for every map: the study's 0, and 1 and 2 cells;
# above 0 the metrics' per-tolerance keys are reported again as KEY_t1, KEY_t2
TOLERANCES = (0, 1, 2)


@dataclass(frozen=True, eq=False)
class WorldInfo:
    """What a worker needs of a world: its key, the truth grid, bounds (xmin, ymin, xmax, ymax)
    and visible surfaces (S, 4) x0, y0, x1, y1 m (World.visible_segments; None for a truth that
    is only a raster: then maps are scored in the study's cell form only)."""

    key: str
    truth: Grid
    bounds: tuple[float, float, float, float]
    source: str = ""
    surfaces: np.ndarray | None = None


_VERSIONS: dict | None = None
_MACHINE: dict | None = None


def versions() -> dict:
    """Versions of the package, simulator, python, numpy and numba (cached per process)."""
    global _VERSIONS
    if _VERSIONS is None:
        import numba
        import sim
        try:
            from importlib.metadata import version
            pkg = version("slam-bench-2d")
        except Exception:
            pkg = "unknown"
        _VERSIONS = {"package": pkg, "sim": str(getattr(sim, "SIM_VERSION", "unknown")),
                     "python": platform.python_version(), "numpy": np.__version__,
                     "numba": numba.__version__}
    return dict(_VERSIONS)


def record_log(world, seed: int, noise: str, lidar: str | None = None):
    """Record the sensor log of `world` (a World) with `seed`, `noise` and `lidar` (a catalogue
    name or lidar YAML; None: the default) (worker job)."""
    import sim
    return sim.record(world, seed=int(seed), noise=noise, lidar=lidar)


_LOGS: dict[str, object] = {}


def _load_log(source):
    """A SensorLog from a path (read once per process; the last few kept) or the log itself."""
    if not isinstance(source, (str, Path)):
        return source
    key = str(source)
    if key not in _LOGS:
        from sim.logs import read_log
        if len(_LOGS) >= 4:
            _LOGS.pop(next(iter(_LOGS)))
        _LOGS[key] = read_log(key)
    return _LOGS[key]


_WARM: set[str] = set()


def warm_up(algo: str, log, config=None) -> None:
    """Run `algo` once per process on the first scans of `log` (its class's warmup_scans),
    untimed and discarded.

    Numba compiles (or loads from its cache) each kernel on first call; without this the
    first repeat in every worker would carry that cost in its wall time and real-time factor.
    Errors are ignored here: the timed run reports them.
    """
    if algo in _WARM:
        return
    _WARM.add(algo)
    import dataclasses
    from slam.registry import get as get_algorithm
    from slam.replay import run_algorithm
    try:
        n = min(int(get_algorithm(algo).warmup_scans), log.n_scans)
        head = dataclasses.replace(log, scan_t=log.scan_t[:n], scan_ranges=log.scan_ranges[:n])
        run_algorithm(algo, head, config=config, seed=0)
    except Exception:
        pass


def compile_algorithm(algo: str, log_source, config=None, algo_cls: type | None = None) -> str:
    """Warm `algo` up in this worker (see warm_up); returns `algo`.

    The runner sends one of these per algorithm before the SLAM tasks, so the workers compile
    different algorithms side by side and each kernel is compiled once, then loaded from
    numba's cache by the other workers, instead of every worker compiling every algorithm.
    """
    from slam import registry
    registry.ensure(algo, algo_cls)
    try:
        warm_up(algo, _load_log(log_source), config)
    except Exception:
        pass  # the timed run reports what is wrong
    return algo


# scans of the log's head the scoring warm-up maps: a few metres of walls, enough that every
# metric (the alignment's ICP among them) runs its compiled path
SCORING_WARMUP_SCANS = 100


def compile_scoring(world: WorldInfo, log_source) -> str:
    """Build the output map of the log's first scans (SCORING_WARMUP_SCANS) at their true
    poses (the start pose for a log without them) and score it against `world`, untimed and
    discarded; returns the world's key.

    Every task builds its map with the same output map and scores it with the same metrics;
    the runner sends this job beside the costliest algorithm's compile job, so those shared
    kernels are compiled once, by one worker, instead of by every algorithm's job at once.
    """
    try:
        from slam.output_map import OutputMapConfig, output_map_from_trajectory
        from slam.pose import interpolate_poses
        from slam.replay import scans_of
        log = _load_log(log_source)
        n = min(SCORING_WARMUP_SCANS, log.n_scans)
        times = log.scan_t[:n]
        if log.has_ground_truth:
            poses = interpolate_poses(times, log.gt_t, log.gt_pose)
        else:
            poses = np.tile(np.asarray(log.start_pose, dtype=np.float64), (n, 1))
        grid = output_map_from_trajectory(OutputMapConfig(), scans_of(log)[:n], times, poses)
        _score(grid, world.truth, world.surfaces)
        if log.has_ground_truth:
            score_trajectory(times, poses, log.gt_t, log.gt_pose)
    except Exception:
        pass  # the tasks report what is wrong
    return world.key


def check_divergence(poses: np.ndarray, bounds, margin: float = DIVERGE_MARGIN_M) -> str | None:
    """None if the (N, 3) trajectory is finite and within `bounds` +- margin, else why not."""
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    if len(poses) == 0:
        return "diverged: empty trajectory"
    bad = ~np.isfinite(poses).all(axis=1)
    if bad.any():
        return f"diverged: non-finite pose at index {int(np.argmax(bad))}"
    xmin, ymin, xmax, ymax = bounds
    out = ((poses[:, 0] < xmin - margin) | (poses[:, 0] > xmax + margin)
           | (poses[:, 1] < ymin - margin) | (poses[:, 1] > ymax + margin))
    if out.any():
        i = int(np.argmax(out))
        return (f"diverged: pose {i} at ({poses[i, 0]:.2f}, {poses[i, 1]:.2f}) m is more than "
                f"{margin:g} m outside the world bounds")
    return None


def _scalars(d: dict) -> dict:
    return {k: v for k, v in d.items() if isinstance(v, (int, float, str, bool, np.generic)) or v is None}


def _score(grid: Grid, truth: Grid, surfaces: np.ndarray | None = None) -> dict:
    """Every registered map metric at tolerance 0 (the surface form at metrics.surface's
    DEFAULT_TAU_M when the world's surfaces (S, 4) are given, under the alignment refined onto
    them: surface_align_*); the per-tolerance keys again at 1 and 2 cells, under the same
    alignment (the SLAM starts at the true pose: ICP refines from identity)."""
    from metrics import registry
    from metrics.score import map_context, score_context
    ctx = map_context(grid, truth, align="auto", initial=(0.0, 0.0, 0.0), tolerance=0,
                      surfaces=surfaces)
    s = score_context(ctx)
    out = _scalars(s)
    al = s["align"]
    out.update({f"align_{k}": float(al[k]) for k in ("x", "y", "yaw")})
    if isinstance(s.get("surface_align"), dict):
        out.update({f"surface_align_{k}": float(s["surface_align"][k]) for k in ("x", "y", "yaw")})
    for tol in TOLERANCES:
        if tol:
            out.update(registry.compute_at_tolerance(ctx.at_tolerance(tol), tol))
    return out


def score_trajectory(times: np.ndarray, poses: np.ndarray, gt_t: np.ndarray,
                     gt_pose: np.ndarray) -> dict:
    """Every registered trajectory metric of (N,) times, (N, 3) poses against the true
    (M,) times, (M, 3) poses."""
    from metrics import registry
    from metrics.trajectory import TrajectoryContext
    return _scalars(registry.compute("trajectory", TrajectoryContext(times, poses, gt_t, gt_pose)))


def _trajectory_scores(result, log) -> dict:
    """Every registered trajectory metric of `result` against the log's true path."""
    return score_trajectory(result.times, result.poses, log.gt_t, log.gt_pose)


def _run_keys() -> list[str]:
    from metrics import registry
    return [k for m in registry.metrics("run") for k in m.keys]


def new_row(task, noise: str = "", vary: str = "slam") -> dict:
    """The fields every row of `task` (bench.plan.Task) has, status "ok" until told otherwise."""
    return {"world": task.world, "algo": task.algo, "repeat": int(task.repeat), "status": "ok",
            "error": None, "log_seed": int(task.log_seed), "slam_seed": int(task.slam_seed),
            "draw": int(task.draw), "noise": str(noise), "vary": vary, "same_as": None,
            "versions": versions(), **machine()}


def machine() -> dict:
    """Where a row was computed: host name and CPU model (cached per process)."""
    global _MACHINE
    if _MACHINE is None:
        cpu = platform.processor() or platform.machine()
        try:
            with open("/proc/cpuinfo", encoding="utf-8") as fh:
                cpu = next((line.split(":", 1)[1].strip() for line in fh
                            if line.startswith("model name")), cpu)
        except OSError:
            pass
        _MACHINE = {"host": platform.node(), "cpu": cpu}
    return dict(_MACHINE)


def failure_fields(err: BaseException) -> dict:
    """The fields a row takes when its run raised `err`: status, a one-line error (the type and
    the message's first line) and the traceback's last frames."""
    msg = str(err).strip().splitlines()[0] if str(err).strip() else ""
    return {"status": "failed", "error": f"{type(err).__name__}: {msg}".rstrip(": "),
            "traceback": "".join(traceback.format_exception(err)[-3:])}


def execute(task, world: WorldInfo, log_source, config=None, noise: str = "", vary: str = "slam",
            algo_cls: type | None = None):
    """Run `task` (bench.plan.Task) on the log; return (row, arrays) (see the module docstring).

    log_source: a path of a cached log or a SensorLog; config: the algorithm's config (None:
    defaults); algo_cls: the algorithm's class, registered here if this worker process does
    not know the name (an algorithm registered in the driving script, sent to a Dask worker).
    arrays: prob (rows, cols), resolution, origin (3,), times (N,), poses (N, 3)
    or None when the SLAM failed before producing a result.
    """
    t0 = time.perf_counter()
    row = new_row(task, noise, vary)
    arrays = None
    try:
        from slam import registry
        from slam.replay import run_algorithm
        registry.ensure(task.algo, algo_cls)
        log = _load_log(log_source)
        warm_up(task.algo, log, config)
        result = run_algorithm(task.algo, log, config=config, seed=int(task.slam_seed))
        stats = dict(result.stats)
        for k in _run_keys():
            if k in stats:
                row[k] = stats.pop(k)
        stats.pop("algo", None)
        stats.pop("seed", None)
        row["slam_stats"] = _scalars(stats)
        arrays = {"prob": result.grid.prob, "resolution": result.grid.resolution,
                  "origin": result.grid.origin, "times": result.times, "poses": result.poses}
        problem = check_divergence(result.poses, world.bounds)
        if problem:
            row.update(status="failed", error=problem)
        else:
            s0 = time.perf_counter()
            row.update(_score(result.grid, world.truth, world.surfaces))
            if log.has_ground_truth:
                row.update(_trajectory_scores(result, log))
            row["score_time_s"] = time.perf_counter() - s0
    except Exception as err:  # a failing SLAM (or scorer) is a result, not a crash
        row.update(failure_fields(err))
    row["task_time_s"] = time.perf_counter() - t0
    row["worker"] = platform.node()
    return row, arrays
