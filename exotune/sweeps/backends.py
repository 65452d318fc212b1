"""Execution backends of a sweep: in-process, local worker processes and Dask.

Each backend computes the chunks ``todo`` with :func:`~exotune.sweeps.compute.chunk_task` and
hands every status record to ``on_result`` in the parent; see the :mod:`exotune.sweeps` package
docstring for the details (in-flight windows, worker start-up, Dask addresses).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import time

from ..errors import ConfigError
from ..jsonio import write_atomic
from .compute import chunk_task
from .store import chunk_file

__all__ = ["dispatch", "stop_signals", "StopSignals", "check_dask_address", "connect_dask", "DaskConnection"]


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
    import signal
    import threading

    # Ctrl-C in a terminal reaches every process of the group: the sweep (the parent) stops the
    # workers itself, so a worker neither prints a KeyboardInterrupt traceback nor fails its chunk.
    # The worker started with SIGINT blocked (_sigint_blocked): one that came during its start-up is
    # pending, and discarded once ignored.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    if sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):
            import ctypes
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="exotune-parent-watch", daemon=True).start()


class StopSignals:
    """The signal that stopped a sweep (:func:`stop_signals`): ``received`` is ``None``,
    ``signal.SIGINT`` (Ctrl-C) or ``signal.SIGTERM`` (``kill PID``); once ``stopping`` (the first
    signal, or :meth:`hold`), further signals are ignored."""

    def __init__(self):
        self.received: int | None = None
        self.stopping = False

    def hold(self) -> None:
        """Ignore SIGINT and SIGTERM from now on (the sweep is recording how it ended)."""
        self.stopping = True


@contextlib.contextmanager
def stop_signals():
    """Ctrl-C (SIGINT) and ``kill PID`` (SIGTERM) stop a sweep the same way: the first one raises
    (``KeyboardInterrupt`` for SIGINT, ``SystemExit(128 + SIGTERM)`` for SIGTERM) and any later
    one, while the sweep stops its workers and records what it has done (or after
    :meth:`StopSignals.hold`), is ignored.

    Handlers are installed in the main thread only (elsewhere signals cannot be handled), and
    SIGINT only over Python's default handler: a Ctrl-C the caller ignores (``SIG_IGN``, a
    background job) or handles itself is left alone. The previous handlers are restored on exit.

    Yields
    ------
    StopSignals
        Its ``received`` is the first of these signals that arrived (None: none).
    """
    import signal
    import threading

    got = StopSignals()
    if threading.current_thread() is not threading.main_thread():
        yield got
        return

    def on_signal(signum, frame):
        if got.stopping:  # already stopping: let the sweep finish recording what it has done
            return
        got.received, got.stopping = signum, True
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        raise SystemExit(128 + signum)

    old = {signal.SIGTERM: signal.signal(signal.SIGTERM, on_signal)}
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        old[signal.SIGINT] = signal.signal(signal.SIGINT, on_signal)
    try:
        yield got
    finally:
        for signum, handler in old.items():
            signal.signal(signum, handler)


@contextlib.contextmanager
def _sigint_blocked():
    """SIGINT blocked in this thread: a worker process started meanwhile inherits the block, so a
    Ctrl-C during its start-up (before :func:`_worker_init` ignores SIGINT) stays pending instead of
    ending it with a KeyboardInterrupt traceback. The sweep itself still gets the Ctrl-C (at the
    latest when the block is lifted)."""
    import signal

    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not POSIX
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _stop_workers(procs, timeout_s: float = 10.0) -> None:
    """Terminate the worker processes ``procs`` (their chunks in progress are recomputed when the
    sweep is resumed) and wait until they have ended (their sentinels: the pool may reap them
    meanwhile), killing any that outlives ``timeout_s``."""
    from multiprocessing.connection import wait

    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    with contextlib.suppress(Exception):
        left = {p.sentinel: p for p in procs}
        deadline = time.monotonic() + timeout_s
        while left and time.monotonic() < deadline:
            for fd in wait(list(left), max(0.0, deadline - time.monotonic())):
                left.pop(fd, None)
        for p in left.values():
            p.kill()


def _run_processes(plan, out_dir, todo, on_result, workers):
    import concurrent.futures as cf
    import multiprocessing as mp
    from concurrent.futures.process import BrokenProcessPool

    window = 2 * workers
    it = iter(todo)
    others = set(mp.active_children())  # the caller's own child processes, never stopped here
    with _single_threaded_blas_env():
        ex = cf.ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                                    initializer=_worker_init, initargs=(os.getpid(),))
        try:
            pending: dict = {}

            def submit_next():
                i = next(it, None)
                if i is not None:
                    with _sigint_blocked():  # a submit may start a worker process
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
        except BaseException:  # Ctrl-C, SIGTERM, …: stop the workers at once, not after their chunks
            ex.shutdown(wait=False, cancel_futures=True)
            _stop_workers([p for p in mp.active_children() if p not in others])
            raise
        ex.shutdown(wait=True)


class DaskConnection:
    """A connected Dask client (and the ``LocalCluster`` started for ``"local"`` / ``"local:N"``);
    :meth:`close` shuts both down. ``address`` is the address the user gave."""

    def __init__(self, address: str, client, cluster=None):
        self.address, self.client, self.cluster = address, client, cluster

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.client.close()
        if self.cluster is not None:
            with contextlib.suppress(Exception):
                self.cluster.close()


_ADDRESS_RE = re.compile(r"^(?:(tcp|tls|ws|wss)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(\d{1,5})$")


def check_dask_address(address, workers: int | None = None) -> tuple[str, int | None]:
    """Validate a ``--dask`` address without connecting: ``("local", N)`` for ``"local"`` /
    ``"local:N"`` (N ≥ 1; default ``workers`` or the CPU count), ``("remote", None)`` for a
    ``[tcp|tls|ws|wss://]host:port`` address (port 1 … 65535) or any ``inproc://…`` / ``ucx://…``
    address.

    Parameters
    ----------
    address : str
        The scheduler address.
    workers : int, optional
        The default number of local workers.

    Returns
    -------
    (str, int or None)
        The kind of address and the number of local workers.

    Raises
    ------
    ConfigError
        A malformed address (field ``dask_address``, the keyword; the command line names
        ``--dask``), one line.

    References
    ----------
    docs/sweep-spec.md (execution, Dask).
    """
    if not isinstance(address, str) or not address.strip():
        raise ConfigError("dask_address", f"expected a scheduler address, got {address!r}")
    if address == "local" or address.startswith("local:"):
        n = workers or os.cpu_count() or 1
        if address.startswith("local:"):
            tail = address.split(":", 1)[1]
            if not tail.isdigit():
                raise ConfigError("dask_address", f"expected 'local' or 'local:N', got {address!r}")
            n = int(tail)
            if n < 1:
                raise ConfigError("dask_address", f"local:N needs N >= 1, got {n}")
        return "local", n
    if address.startswith(("inproc://", "ucx://")):
        return "remote", None
    mt = _ADDRESS_RE.match(address)
    if mt is None or not 1 <= int(mt.group(3)) <= 65535:
        raise ConfigError("dask_address", f"expected a scheduler address [tcp://]host:port (port 1 … 65535), "
                                          f"'local' or 'local:N', got {address[:80]!r}")
    return "remote", None


def _reachable(address: str, timeout_s: float = 5.0) -> None:
    """A TCP connection to a ``host:port`` scheduler address, opened and closed (fails fast on a
    refused or unresolvable address instead of the client's retries)."""
    import socket

    mt = _ADDRESS_RE.match(address)
    if mt is None or (mt.group(1) or "tcp") not in ("tcp", "tls"):
        return
    host = mt.group(2).strip("[]")
    try:
        with socket.create_connection((host, int(mt.group(3))), timeout=timeout_s):
            pass
    except OSError as e:
        raise ConfigError("dask_address", f"cannot connect to the Dask scheduler at {address!r}: "
                                          f"{e.strerror or type(e).__name__}") from None


def connect_dask(address: str, workers: int | None) -> DaskConnection:
    """Validate ``address`` (:func:`check_dask_address`) and connect: start a ``LocalCluster`` for
    ``"local"``/``"local:N"``, else connect a :class:`distributed.Client` (a TCP probe first, so an
    unreachable scheduler fails in seconds). Every failure is one ConfigError naming ``dask_address``;
    :func:`~exotune.sweeps.run.run_sweep` calls it before creating the sweep directory.

    Parameters
    ----------
    address : str
        ``"local"``, ``"local:N"`` or a scheduler address.
    workers : int, optional
        Local workers of ``"local"`` (default the CPU count).

    Returns
    -------
    DaskConnection
        Close it when the sweep is done.

    References
    ----------
    docs/sweep-spec.md (execution, Dask).
    """
    kind, n = check_dask_address(address, workers)
    try:
        from distributed import Client, LocalCluster
    except ImportError as e:  # pragma: no cover - dask[distributed] is a dependency
        raise ConfigError("dask_address", f"dask.distributed is not installed ({e})") from None
    if kind == "local":
        try:
            # its processes (and the thread that starts them) inherit SIGINT blocked: Ctrl-C in the
            # terminal stops the sweep, which closes the cluster, without a traceback from each worker
            with _single_threaded_blas_env(), _sigint_blocked():
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
        except Exception as e:
            raise ConfigError("dask_address", f"cannot start a local Dask cluster of {n} workers: "
                                              f"{' '.join(str(e).split())[:200]}") from None
        return DaskConnection(address, Client(cluster), cluster)
    _reachable(address)
    try:
        client = Client(address, timeout="20s")
    except Exception as e:
        raise ConfigError("dask_address", f"cannot connect to the Dask scheduler at {address!r}: "
                                          f"{' '.join(str(e).split())[:200]}") from None
    return DaskConnection(address, client)


def _run_dask(plan, out_dir, todo, on_result, conn: DaskConnection, workers):
    from distributed import as_completed

    client = conn.client
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


def dispatch(plan, out_dir, todo, on_result, backend, dask, workers, n_workers) -> None:
    """Compute the chunks ``todo`` of ``plan`` with ``backend`` (``"in-process"``,
    ``"local-processes"`` with ``n_workers`` processes, or ``"dask"`` on the
    :class:`DaskConnection` ``dask``), calling
    ``on_result(status record)`` in this process for every chunk, failed ones included.

    Parameters
    ----------
    plan : SweepPlan
        The sweep's plan.
    out_dir : str
        The sweep directory the chunk files are written to.
    todo : list of int
        Indices of the chunks to compute.
    on_result : callable
        Called with each chunk's status record (a dict with ``index``, ``rows``, ``error``, …).
    backend : str
        ``"in-process"``, ``"local-processes"`` or ``"dask"``.
    dask : DaskConnection or None
        The Dask connection (backend ``"dask"``).
    workers : int or None
        The requested worker count (the Dask window's fallback when the cluster reports none).
    n_workers : int
        Worker processes of ``"local-processes"``.
    """
    if not todo:
        return
    if backend == "dask":
        _run_dask(plan, out_dir, todo, on_result, dask, workers)
    elif backend == "in-process":
        _run_inprocess(plan, out_dir, todo, on_result)
    else:
        _run_processes(plan, out_dir, todo, on_result, n_workers)
