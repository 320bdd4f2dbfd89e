"""`python -m bench speed`: the real-time factor (log duration / wall time) of the simulator and
of each algorithm on the shipped worlds, median of `runs`, one core, this machine's CPU named.

The simulator is timed recording each world's log (seed 0, the noise profile given; one untimed
recording first); each
algorithm on that log, after an untimed warm-up (numba compilation is not counted), with the
wall time from its stats.json-equivalent `wall_time_s`. Everything runs in this process, one
after the other, so the figures are comparable between machines and commits.
"""
from __future__ import annotations

import statistics
import time

from worlds.yamlio import InputError

__all__ = ["speed_table"]


def speed_table(worlds: list[str], algos: list[str], runs: int = 3, noise: str = "realistic",
                stream=None) -> str:
    """A Markdown table: world, log duration, then the median real-time factor of the
    simulator and of each algorithm (and the spread of the runs)."""
    import sim
    from bench.task import machine, warm_up
    from slam.replay import run_algorithm
    from worlds import load_world
    if runs < 1:
        raise InputError(f"--runs must be >= 1, got {runs}")
    lines = [f"CPU: {machine()['cpu']} ({machine()['host']}); median of {runs} runs, one core",
             "", "| world | log (s) | simulator | " + " | ".join(algos) + " |",
             "|---|---|---|" + "---|" * len(algos)]
    for i, name in enumerate(worlds):
        world = load_world(name)
        if i == 0:
            sim.record(world, seed=0, noise=noise)   # untimed: the simulator's kernels compile
        sim_rtf, log = [], None
        for _ in range(runs):
            t0 = time.perf_counter()
            log = sim.record(world, seed=0, noise=noise)
            sim_rtf.append(log.duration / (time.perf_counter() - t0))
        cells = [_cell(sim_rtf)]
        for algo in algos:
            warm_up(algo, log)
            rtf = [run_algorithm(algo, log, seed=k).stats["realtime_factor"] for k in range(runs)]
            cells.append(_cell(rtf))
        lines.append(f"| {world.name} | {log.duration:.0f} | " + " | ".join(cells) + " |")
        if stream is not None:
            print(lines[-1], file=stream, flush=True)
    return "\n".join(lines)


def _cell(values: list[float]) -> str:
    return f"{statistics.median(values):.1f}x ({min(values):.1f}-{max(values):.1f})"
