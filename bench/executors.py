"""Where tasks run: in this process, in a local process pool, or on a Dask cluster.

All three have the same small interface, so the runner does not care:
  submit(fn, *args) -> future;  wait_any(futures) -> (done, not_done);  scatter(obj) -> handle
  result(future) -> value;  shutdown(cancel=True)
Futures are concurrent.futures.Future for the local kinds and distributed.Future for Dask.
Dask is an optional extra (`pip install .[dask]`), imported only when a scheduler is given.
"""
from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import signal
import threading
import time

from worlds.yamlio import InputError

__all__ = ["make_executor", "InlineExecutor", "PoolExecutor", "DaskExecutor"]


# how often a worker looks whether its parent is still there: a dead runner's workers are
# gone within this, and two getppid() calls a second cost nothing a run could notice
_PARENT_POLL_S = 0.5


def _worker_init() -> None:
    """A pool worker: ignores Ctrl-C (the runner handles it once and stops the workers itself)
    and dies with its parent, whatever signal ends it. Two guards: Linux delivers SIGKILL when
    the parent dies (prctl PR_SET_PDEATHSIG), and a thread polls for the parent everywhere,
    also where the signal is armed but never delivered (gVisor's sandboxed kernel)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _arm_parent_death_signal()
    # the pid multiprocessing started us from, not getppid(): if the runner died already,
    # getppid() names whoever adopted us (and a runner may itself be pid 1, in a container)
    started_by = multiprocessing.parent_process()
    parent = started_by.pid if started_by is not None else os.getppid()
    if os.getppid() != parent:   # orphaned before the guards were up
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent,), name="watch-parent",
                     daemon=True).start()


def _arm_parent_death_signal() -> bool:
    """Ask Linux for SIGKILL when the parent dies; whether the kernel took the request (a
    kernel may take it and still never send the signal: see _worker_init)."""
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        return libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent: int, poll_s: float = _PARENT_POLL_S) -> None:
    """End this process once its parent `parent` is gone (it is then re-parented)."""
    while os.getppid() == parent:
        time.sleep(poll_s)
    os._exit(1)


class InlineExecutor:
    """Runs each task in this process when the runner waits for it (jobs=1; debuggers, tests)."""

    workers = 1

    def __init__(self):
        self._todo: dict[cf.Future, tuple] = {}

    def submit(self, fn, *args):
        fut = cf.Future()
        self._todo[fut] = (fn, args)
        return fut

    def scatter(self, obj):
        return obj

    def wait_any(self, futures):
        futures = set(futures)
        done = {f for f in futures if f.done()}
        if not done:
            fut = next(f for f in self._todo if f in futures)  # submission order
            fn, args = self._todo.pop(fut)
            try:
                fut.set_result(fn(*args))
            except Exception as err:
                fut.set_exception(err)
            done = {fut}
        return done, futures - done

    def result(self, fut):
        return fut.result()

    def shutdown(self, cancel: bool = True):
        self._todo.clear()


class PoolExecutor:
    """A concurrent.futures ProcessPoolExecutor with `jobs` worker processes.

    Workers live for the whole run, so each compiles the numba kernels once (and numba's
    on-disk cache makes later runs skip even that).
    """

    def __init__(self, jobs: int):
        self.workers = jobs
        self.pool = cf.ProcessPoolExecutor(max_workers=jobs, initializer=_worker_init)

    def submit(self, fn, *args):
        return self.pool.submit(fn, *args)

    def scatter(self, obj):
        return obj

    def wait_any(self, futures):
        done, rest = cf.wait(futures, return_when=cf.FIRST_COMPLETED)
        return done, rest

    def result(self, fut):
        return fut.result()

    def shutdown(self, cancel: bool = True):
        if cancel:
            # a running SLAM may take minutes: stop the workers instead of waiting for them
            procs = list(getattr(self.pool, "_processes", {}).values())
            self.pool.shutdown(wait=False, cancel_futures=True)
            for proc in procs:
                if proc.is_alive():
                    proc.terminate()
            for proc in procs:
                proc.join(timeout=5)
        else:
            self.pool.shutdown(wait=True)


class DaskExecutor:
    """Tasks sent to a dask.distributed scheduler at `address` ('local' starts a LocalCluster).

    Logs and truth grids travel with the tasks (scattered once), so workers need neither the
    log cache nor the world files; the client writes every result.
    """

    def __init__(self, address: str, jobs: int | None = None):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise InputError("--scheduler needs dask.distributed: pip install 'slam-bench-2d[dask]' "
                             "(or pip install 'dask[distributed]')") from None
        self._cluster = None
        try:
            if address == "local":
                self._cluster = LocalCluster(n_workers=jobs or os.cpu_count() or 1,
                                             threads_per_worker=1, processes=True,
                                             dashboard_address=":0")
                self.client = Client(self._cluster)
            else:
                self.client = Client(address, timeout="20s")
        except (OSError, TimeoutError) as err:
            raise InputError(f"--scheduler {address}: cannot connect: {err}") from None
        info = self.client.scheduler_info()
        self.workers = max(1, sum(w.get("nthreads", 1) for w in info.get("workers", {}).values()))

    def submit(self, fn, *args):
        return self.client.submit(fn, *args, pure=False)

    def scatter(self, obj):
        return self.client.scatter(obj, broadcast=False)

    def wait_any(self, futures):
        from distributed import wait
        res = wait(list(futures), return_when="FIRST_COMPLETED")
        return set(res.done), set(res.not_done)

    def result(self, fut):
        return fut.result()

    def shutdown(self, cancel: bool = True):
        self.client.close()
        if self._cluster is not None:
            self._cluster.close()


def make_executor(jobs: int | None = None, scheduler: str | None = None):
    """Dask when `scheduler` is given, else inline for jobs == 1, else a process pool."""
    if scheduler:
        return DaskExecutor(scheduler, jobs)
    jobs = jobs or os.cpu_count() or 1
    if jobs < 1:
        raise InputError(f"--jobs must be >= 1, got {jobs}")
    return InlineExecutor() if jobs == 1 else PoolExecutor(jobs)
