"""Execution backends of a sweep: in-process, local worker processes and Dask.

Each backend computes the chunks ``todo`` with :func:`~exotune.sweep.compute.chunk_task` and
hands every status record to ``on_result`` in the parent; see the :mod:`exotune.sweep` package
docstring for the details (in-flight windows, worker start-up, Dask addresses).
"""

from __future__ import annotations

import contextlib
import os
import sys
import time

from ..errors import ConfigError
from ..jsonio import write_atomic
from .compute import chunk_task
from .progress import SweepProgress
from .store import chunk_file

__all__ = ["dispatch", "sigterm_as_exit"]


@contextlib.contextmanager
def _single_threaded_blas_env():
    keys = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    old = {k: os.environ.get(k) for k in keys}
    for k in keys:
        os.environ.setdefault(k, "1")
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _run_inprocess(plan, out_dir, todo, on_result):
    for i in todo:
        on_result(chunk_task(plan.spec, plan.hash, i, out_dir))


def _worker_init(parent_pid: int) -> None:
    """Sweep worker start-up: never outlive the sweep. Linux kills the worker with the parent
    (``PR_SET_PDEATHSIG``); elsewhere, and as a second line, a daemon thread exits once the
    parent is gone (re-parented). Without this a ``kill -9`` of ``exotune sweep`` left its idle
    workers blocked on their pipe for ever, each holding ~200 MB."""
    import threading

    if sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):
            import ctypes
            import signal

            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="exotune-parent-watch", daemon=True).start()


@contextlib.contextmanager
def sigterm_as_exit(progress: SweepProgress):
    """SIGTERM (``kill PID``) ends the sweep like Ctrl-C: the manifest records "interrupted" and
    the worker pool is shut down (only the main thread can install a handler). The termination
    is reported as ``progress.message("terminated", …)``."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_term(signum, frame):
        progress.message("terminated", "exotune sweep: terminated (SIGTERM); rerun the same command to resume")
        raise SystemExit(128 + signum)

    old = signal.signal(signal.SIGTERM, on_term)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _run_processes(plan, out_dir, todo, on_result, workers):
    import concurrent.futures as cf
    import multiprocessing as mp
    from concurrent.futures.process import BrokenProcessPool

    window = 2 * workers
    it = iter(todo)
    with _single_threaded_blas_env():
        ex = cf.ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                                    initializer=_worker_init, initargs=(os.getpid(),))
        try:
            pending: dict = {}

            def submit_next():
                i = next(it, None)
                if i is not None:
                    pending[ex.submit(chunk_task, plan.spec, plan.hash, i, out_dir)] = i

            for _ in range(window):
                submit_next()
            while pending:
                done, _ = cf.wait(list(pending), return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    i = pending.pop(fut)
                    try:
                        res = fut.result()
                    except BrokenProcessPool as e:
                        res = {"index": i, "rows": 0, "schema": None, "seconds": 0.0,
                               "error": f"worker process died (BrokenProcessPool: {e})"}
                    except Exception as e:  # pragma: no cover - chunk_task does not raise
                        res = {"index": i, "rows": 0, "schema": None, "seconds": 0.0,
                               "error": f"{type(e).__name__}: {e}"}
                    on_result(res)
                    submit_next()
        except BaseException:
            ex.shutdown(wait=False, cancel_futures=True)
            raise
        ex.shutdown(wait=True)


def _dask_client(address: str, workers: int | None):
    try:
        from distributed import Client, LocalCluster
    except ImportError as e:  # pragma: no cover - dask[distributed] is a dependency
        raise ConfigError("dask", f"dask.distributed is not installed ({e})") from None
    cluster = None
    if address == "local" or address.startswith("local:"):
        n = workers or os.cpu_count() or 1
        if address.startswith("local:"):
            try:
                n = int(address.split(":", 1)[1])
            except ValueError:
                raise ConfigError("dask", f"expected 'local' or 'local:N', got {address!r}") from None
            if n < 1:
                raise ConfigError("dask", f"local:N needs N >= 1, got {n}")
        with _single_threaded_blas_env():
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    else:
        try:
            client = Client(address, timeout="20s")
        except (OSError, TimeoutError, ValueError) as e:
            raise ConfigError("dask", f"cannot connect to the Dask scheduler at {address!r}: {e}") from None
    return client, cluster


def _run_dask(plan, out_dir, todo, on_result, address, workers):
    from distributed import as_completed

    client, cluster = _dask_client(address, workers)
    try:
        try:
            nthreads = sum(client.nthreads().values()) or 1
        except Exception:  # pragma: no cover
            nthreads = workers or 1
        window = 2 * nthreads
        it = iter(todo)
        ac = as_completed()
        index_of = {}

        def submit_next():
            i = next(it, None)
            if i is not None:
                fut = client.submit(chunk_task, plan.spec, plan.hash, i, None, pure=False)
                index_of[fut.key] = i
                ac.add(fut)

        for _ in range(window):
            submit_next()
        for fut in ac:
            i = index_of.pop(fut.key)
            try:
                res = fut.result()
            except Exception as e:
                res = {"index": i, "rows": 0, "schema": None, "seconds": 0.0,
                       "error": " ".join(f"Dask task failed: {type(e).__name__}: {e}".split())}
            fut.release()
            del fut
            data = res.pop("data", None)
            if res.get("error") is None and data is not None:
                try:
                    write_atomic(chunk_file(out_dir, i), data)
                except OSError as e:
                    res["error"] = f"cannot write the chunk file: {e}"
            del data
            on_result(res)
            submit_next()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def dispatch(plan, out_dir, todo, on_result, backend, dask_address, workers, n_workers) -> None:
    """Compute the chunks ``todo`` of ``plan`` with ``backend`` (``"in-process"``,
    ``"local-processes"`` with ``n_workers`` processes, or ``"dask"`` at ``dask_address``), calling
    ``on_result(status record)`` in this process for every chunk, failed ones included."""
    if not todo:
        return
    if backend == "dask":
        _run_dask(plan, out_dir, todo, on_result, dask_address, workers)
    elif backend == "in-process":
        _run_inprocess(plan, out_dir, todo, on_result)
    else:
        _run_processes(plan, out_dir, todo, on_result, n_workers)
