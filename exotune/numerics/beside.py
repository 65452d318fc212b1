"""One independent computation run in a forked child process beside the caller's own work.

``exotune analyze`` has two independent halves of about equal cost: the plant-uncertainty margin
(box proofs and vertex counts) and everything else (the analysis, the latency margins, the
sampled-data verdicts of record). On a machine with two or more cores, :func:`beside` starts the
first in a child process created by ``fork`` (it inherits the parent's memory: the design, the
loaded modules and compiled kernels, nothing is sent to it), the caller computes the rest, and
:meth:`Beside.result` collects the child's result (pickled through a pipe). The child runs the
same function on the same inputs, so the result is the one a serial run gives, bit for bit.

The child is used only when it is safe and pays off; otherwise the function simply runs in the
caller's process when :meth:`Beside.result` is called:

* the system is Linux (macOS's system libraries, e.g. the Accelerate BLAS, are not safe to use
  in a forked child that does not exec), the process has one Python thread (forking a threaded
  process can leave a lock held forever in the child), at least two CPUs are usable,
  ``EXOTUNE_SERIAL`` is unset and the work is not inside :func:`serial` (a sweep's workers already
  use every core);
* the same ``key`` has already run once in this process, or the process has declared itself
  one-shot (:func:`one_shot`: the command line runs one command per process). Otherwise the first
  run is serial, so that the modules and compiled kernels it loads stay loaded in the parent: a
  child's imports die with it, and repeated calls would otherwise pay them every time.

Any failure of the child (an exception, a signal, a result that does not unpickle, no result
within :data:`STALL_S` of the call of :meth:`Beside.result`) makes :meth:`Beside.result` run the
function in the caller's process, where an exception propagates as usual. Leaving the ``with``
block without collecting the result kills and reaps the child.

References
----------
docs/architecture.md#engines.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import pickle
import select
import signal
import sys
import threading
import time

__all__ = ["Beside", "beside", "can_fork", "one_shot", "serial"]

STALL_S = 600.0  # the longest wait for a child's result [s] before the caller computes it itself
_SEEN: set = set()  # keys that have run once in this process (serially)
_ONE_SHOT: contextvars.ContextVar[bool] = contextvars.ContextVar("exotune_one_shot", default=False)
_SERIAL: contextvars.ContextVar[bool] = contextvars.ContextVar("exotune_serial", default=False)


@contextlib.contextmanager
def serial():
    """Run the enclosed work without child processes: work that is already spread over the cores
    (a sweep's workers, one design each at a time) gains nothing from more processes.

    Examples
    --------
    >>> with serial():
    ...     can_fork()
    False
    """
    token = _SERIAL.set(True)
    try:
        yield
    finally:
        _SERIAL.reset(token)


@contextlib.contextmanager
def one_shot():
    """Declare the enclosed work the process's only work (``exotune analyze`` on the command line):
    a computation may run in a child process already on its first run, since nothing the child
    loads would serve a later run.

    Examples
    --------
    >>> with one_shot():
    ...     pass
    """
    token = _ONE_SHOT.set(True)
    try:
        yield
    finally:
        _ONE_SHOT.reset(token)


def can_fork() -> bool:
    """Whether a child process may be forked here (module docstring's first rule).

    Returns
    -------
    bool
        Linux, one Python thread, ≥ 2 usable CPUs, ``EXOTUNE_SERIAL`` unset and not inside
        :func:`serial`.
    """
    if (os.environ.get("EXOTUNE_SERIAL") or _SERIAL.get() or not sys.platform.startswith("linux")
            or not hasattr(os, "fork") or threading.active_count() != 1):
        return False
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
    return cpus >= 2


class Beside:
    """A computation started by :func:`beside`; :meth:`result` returns its value.

    Attributes
    ----------
    key : hashable
        What the computation is (:func:`beside`'s ``key``).
    forked : bool
        Whether it runs in a child process (False: it runs in the caller at :meth:`result`).
    """

    def __init__(self, key, fn, args, kwargs):
        self.key = key
        self._fn, self._args, self._kwargs = fn, args, kwargs
        self._pid = None
        self._fd = None
        self._done = False
        self._value = None
        self.forked = False
        if (key in _SEEN or _ONE_SHOT.get()) and can_fork():
            self._start()
        _SEEN.add(key)

    def _start(self) -> None:
        r, w = os.pipe()
        try:
            pid = os.fork()
        except OSError:
            os.close(r)
            os.close(w)
            return
        if pid == 0:  # the child: compute, send, leave without running the parent's exit handlers
            code = 1
            try:
                os.close(r)
                signal.signal(signal.SIGINT, signal.SIG_DFL)  # Ctrl-C ends the child at once
                data = pickle.dumps(self._fn(*self._args, **self._kwargs), protocol=pickle.HIGHEST_PROTOCOL)
                view = memoryview(data)
                while view:
                    view = view[os.write(w, view):]
                code = 0
            except BaseException:  # noqa: BLE001 - reported through the exit code; the parent recomputes
                code = 1
            finally:
                os._exit(code)
        os.close(w)
        self._pid, self._fd, self.forked = pid, r, True

    def _collect(self):
        """The child's value, or raise LookupError when it failed."""
        chunks = []
        deadline = time.monotonic() + STALL_S
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._fd], [], [], left)[0]:
                self.close()  # stalled: kill it, compute here
                raise LookupError("the child process gave no result in time")
            b = os.read(self._fd, 1 << 20)
            if not b:
                break
            chunks.append(b)
        os.close(self._fd)
        self._fd = None
        _, status = os.waitpid(self._pid, 0)
        self._pid = None
        if not (os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0):
            raise LookupError("the child process failed")
        try:
            return pickle.loads(b"".join(chunks))
        except Exception as e:  # noqa: BLE001 - any unpickling failure: recompute here
            raise LookupError("the child's result did not unpickle") from e

    def result(self):
        """The function's value: the child's, or computed here (serial run, or the child failed).

        Returns
        -------
        object
            What the function returned.
        """
        if self._done:
            return self._value
        value, ok = None, False
        if self._pid is not None:
            try:
                value, ok = self._collect(), True
            except LookupError:
                ok = False
        if not ok:
            value = self._fn(*self._args, **self._kwargs)
        self._value, self._done = value, True
        return value

    def close(self) -> None:
        """Kill and reap a child whose result was not collected (idempotent)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        if self._pid is not None:
            try:
                os.kill(self._pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            os.waitpid(self._pid, 0)
            self._pid = None

    def __enter__(self) -> "Beside":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def beside(key, fn, *args, **kwargs) -> Beside:
    """Start ``fn(*args, **kwargs)`` in a forked child process when that is safe and the ``key``
    has run before in this process (module docstring); use as a context manager and call
    :meth:`Beside.result` for the value.

    Parameters
    ----------
    key : hashable
        What the computation is (its first run in a process is serial, later ones may fork).
    fn : callable
        A pure function of its arguments; its result must pickle.
    *args, **kwargs
        Its arguments.

    Returns
    -------
    Beside
        The started computation.

    Examples
    --------
    >>> with beside("doc example", sum, [1, 2, 3]) as job:
    ...     job.result()
    6
    """
    return Beside(key, fn, args, kwargs)
