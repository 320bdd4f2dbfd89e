import numpy as np

from bench.task import check_divergence


def test_divergence_rules():
    b = (0.0, 0.0, 3.0, 2.0)
    ok = np.array([[0.5, 0.5, 0.0], [4.9, 3.9, 1.0], [-1.9, -1.9, 0.0]])
    assert check_divergence(ok, b) is None
    assert "non-finite pose at index 1" in check_divergence(np.array([[0, 0, 0], [np.nan, 0, 0]]), b)
    msg = check_divergence(np.array([[0, 0, 0], [5.1, 0, 0]]), b)
    assert msg.startswith("diverged: pose 1") and "2 m outside" in msg
    assert "empty" in check_divergence(np.zeros((0, 3)), b)


def test_the_warm_up_reaches_every_stage_of_graph(monkeypatch):
    """The untimed warm-up must run every compiled kernel once, or the first timed run pays
    for compiling it: for graph that is its loop-closure search, which starts only once its
    first submap is finished."""
    import dataclasses

    import bench.task as task
    import sim
    from slam.graph import GraphSlam
    from slam.replay import run_algorithm
    from worlds import load_world

    log = sim.record(load_world("corridor"), seed=0)
    assert log.n_scans > GraphSlam.warmup_scans
    seen = []
    monkeypatch.setattr("slam.replay.run_algorithm",
                        lambda algo, head, **kw: seen.append(run_algorithm(algo, head, **kw)))
    monkeypatch.setattr(task, "_WARM", set())
    task.warm_up("graph", log)
    assert len(seen) == 1 and seen[0].stats["scans_processed"] == GraphSlam.warmup_scans
    assert seen[0].stats["loop_closure_attempts"] > 0
    assert seen[0].stats["optimizations"] > 0
    short = dataclasses.replace(log, scan_t=log.scan_t[:12], scan_ranges=log.scan_ranges[:12])
    assert run_algorithm("graph", short).stats["loop_closure_attempts"] == 0
