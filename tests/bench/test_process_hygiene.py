"""A run's workers die with it, whatever signal ends it; a folder takes one run at a time."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bench.__main__ import main

ROOT = Path(__file__).resolve().parents[2]
DRIVER = "import sys, tests.bench.fakes; from bench.__main__ import main; sys.exit(main(sys.argv[1:]))"


def _children(pid: int) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(d.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _slow_run(tiny, out, tmp_path):
    """A bench run in its own process whose fake_map runs sleep 60 s each."""
    cfg = tmp_path / "slow.yaml"
    cfg.write_text("delay_s: 60\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-c", DRIVER, "run", "--world", tiny, "--algo", "fake_map",
                             "--repeats", "4", "--jobs", "2", "--no-progress", "--no-figures",
                             "--config", f"fake_map={cfg}", "--out", str(out)],
                            cwd=ROOT, env=env, stderr=subprocess.PIPE, stdout=subprocess.PIPE)


def _wait_for(cond, timeout=120.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if cond():
            return True
        time.sleep(0.2)
    return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
@pytest.mark.slow
def test_kill_9_of_the_runner_leaves_no_worker_alive(tiny, tmp_path):
    proc = _slow_run(tiny, tmp_path / "run", tmp_path)
    try:
        assert _wait_for(lambda: len(_children(proc.pid)) >= 2), proc.stderr.read1(4000)
        workers = _children(proc.pid)
        time.sleep(2.0)   # the workers are inside a run
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        assert _wait_for(lambda: not any(_alive(w) for w in workers), timeout=5.0), \
            [w for w in workers if _alive(w)]
    finally:
        if proc.poll() is None:
            proc.kill()
        for w in _children(proc.pid):
            os.kill(w, signal.SIGKILL)


def _worker_state():
    """In a pool worker: (whether the parent-death signal can be armed here, thread names)."""
    import threading

    from bench.executors import _arm_parent_death_signal
    return _arm_parent_death_signal(), [t.name for t in threading.enumerate()]


def test_the_parent_watch_runs_even_where_the_death_signal_is_armed():
    """gVisor arms PR_SET_PDEATHSIG and never delivers it: the watch must not depend on
    whether arming worked."""
    from bench.executors import PoolExecutor
    pool = PoolExecutor(1)
    try:
        armed, threads = pool.result(pool.submit(_worker_state))
    finally:
        pool.shutdown()
    if sys.platform.startswith("linux"):
        assert armed
    assert "watch-parent" in threads


# a runner whose kernel takes the parent-death request and never sends the signal (gVisor)
NO_SIGNAL_RUNNER = """
import os, sys, time
import bench.executors as ex
ex._arm_parent_death_signal = lambda: True
pool = ex.PoolExecutor(1)
print(pool.result(pool.submit(os.getpid)), flush=True)
time.sleep(60)
"""


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_workers_die_with_a_killed_runner_without_the_death_signal():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", NO_SIGNAL_RUNNER], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    worker = None
    try:
        worker = int(proc.stdout.readline() or 0)
        assert worker and _alive(worker), proc.stderr.read()
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        assert _wait_for(lambda: not _alive(worker), timeout=5.0)   # the watch polls at 0.5 s
    finally:
        if proc.poll() is None:
            proc.kill()
        if worker and _alive(worker):
            os.kill(worker, signal.SIGKILL)


@pytest.mark.slow
def test_a_second_run_on_a_busy_folder_refuses_at_once(tiny, tmp_path, capsys):
    out = tmp_path / "run"
    proc = _slow_run(tiny, out, tmp_path)
    try:
        assert _wait_for(lambda: (out / "run.json").exists()), proc.stderr.read1(4000)
        t0 = time.monotonic()
        assert main(["run", "--resume", str(out), "--jobs", "1", "--no-figures"]) == 2
        assert time.monotonic() - t0 < 5
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"in use by another bench run (pid {proc.pid})" in err[0], err
    finally:
        proc.kill()
        proc.wait()
    # the lock dies with its holder (and its workers, which share the open lock file)
    from bench.rundir import run_lock
    from worlds.yamlio import InputError

    def free():
        try:
            with run_lock(out):
                return True
        except InputError:
            return False
    assert _wait_for(free, timeout=5.0)


def test_arrays_are_written_atomically_under_unique_names(tmp_path, monkeypatch):
    """The runner's arrays (maps, true map, true path) go through a unique temporary file and a
    rename: a kill mid-write leaves no partial file that a resume would take as done."""
    import numpy as np

    import worlds.yamlio as yamlio
    from bench import rundir

    calls = []
    real_mkstemp = yamlio.tempfile.mkstemp

    def spy(*args, **kw):
        fd, name = real_mkstemp(*args, **kw)
        calls.append(name)
        return fd, name
    monkeypatch.setattr(yamlio.tempfile, "mkstemp", spy)
    log = type("Log", (), {"has_ground_truth": True, "gt_t": np.arange(3.0), "gt_pose": np.zeros((3, 3))})()
    rundir.save_gt(tmp_path, "w", 0, log)
    rundir.save_gt(tmp_path, "w", 1, log)
    assert len(calls) == 2 and len(set(calls)) == 2
    assert not [p for p in tmp_path.rglob("*") if "tmp" in p.name]

    def interrupted(path, data):
        raise KeyboardInterrupt
    monkeypatch.setattr(rundir, "atomic_write_bytes", interrupted)
    with pytest.raises(KeyboardInterrupt):
        rundir.save_gt(tmp_path, "w", 2, log)
    assert not (tmp_path / "maps" / "w" / "gt_s2.npz").exists()
