"""--scheduler: the same tasks on a Dask LocalCluster give the same rows as local processes."""
import pytest

from bench import RunSpec, comparable, read_rows, run_benchmark

distributed = pytest.importorskip("distributed")


def test_local_cluster_matches_local_run(tiny, tmp_path):
    spec = RunSpec(worlds=(tiny,), algos=("fake_map", "fake_raise"), repeats=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        out = run_benchmark(spec, tmp_path / "dask", scheduler=cluster.scheduler_address,
                            progress=False)
    assert out.complete and (out.ok, out.failed) == (2, 2)
    local = run_benchmark(spec, tmp_path / "local", jobs=1, progress=False)
    assert local.complete
    assert comparable(read_rows(tmp_path / "dask")) == comparable(read_rows(tmp_path / "local"))
    assert (tmp_path / "dask" / "maps" / "tiny" / "fake_map" / "0.npz").exists()


def test_a_tune_runs_its_trials_on_a_cluster(tmp_path):
    from pathlib import Path
    from bench.tune import TuneSpec, tune
    suite = tmp_path / "dev.yaml"
    suite.write_text(f"name: dev\ndraws: 2\nworlds:\n  - {Path(__file__).with_name('tiny_world.yaml')}\n")
    space = tmp_path / "space.yaml"
    space.write_text("params:\n  pose_noise_m: {low: 0.001, high: 0.05, log: true}\n")
    spec = TuneSpec(algo="fake_map", suite=str(suite), space=str(space), trials=3, objective="ate")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        out = tune(spec, tmp_path / "dask", scheduler=cluster.scheduler_address, progress=False)
    local = tune(spec, tmp_path / "local", jobs=1, progress=False)
    assert out.complete == 3 and (out.best_number, out.best_value) == (local.best_number,
                                                                      local.best_value)
