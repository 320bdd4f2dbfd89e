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
