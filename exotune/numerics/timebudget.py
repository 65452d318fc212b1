"""The time budget of ``exotune export`` and ``exotune certify``: their sampled-data analysis
solves thousands of eigenvalue problems whose size grows with the delay in samples (a 1 ms delay
at 100 kHz is a 120-state loop matrix), so a high rate can turn seconds into hours.

Two guards, both raising :class:`~exotune.errors.ConfigError` on ``--time-budget-s`` (exit 2,
nothing written — the controller file is written only at the end, atomically):

* **before starting**, :func:`refuse_if_over` (called by
  :func:`exotune.controllerfile.certify.refuse_excess_work`) compares a *lower bound* of the work — the base grid
  of every family, for the file and each gain-schedule entry, times the measured cost of one
  eigenvalue problem of the loop's size — with the budget;
* **while running**, :func:`check_time` (called before every eigenvalue problem of the
  sampled-data loop, :mod:`exotune.sampled.loop`) stops the
  analysis once the budget is spent (refinement near the unit circle can multiply the base work
  tenfold at high rates).

References
----------
docs/cli.md#export, docs/controller-file.md.
"""

from __future__ import annotations

import contextlib
import contextvars
import time

import numpy as np

from ..errors import ConfigError
from ..units import fmt_num
from .threads import one_blas_thread

__all__ = ["DEFAULT_TIME_BUDGET_S", "time_budget", "check_time", "eig_seconds", "refuse_if_over", "check_budget_option",
           "active_budget"]

DEFAULT_TIME_BUDGET_S = 600.0
FIELD = "time_budget_s"
_DEADLINE: contextvars.ContextVar = contextvars.ContextVar("exotune_time_budget", default=None)


def check_budget_option(value) -> float:
    """``--time-budget-s``: a positive, finite number of seconds (default :data:`DEFAULT_TIME_BUDGET_S`).

    Parameters
    ----------
    value : Any
        The option's value (a number or its text); None for the default.

    Returns
    -------
    float
        The budget [s].

    Raises
    ------
    exotune.errors.ConfigError
        When the value is not a positive, finite number.
    """
    from ..options import number_value

    return DEFAULT_TIME_BUDGET_S if value is None else number_value(FIELD, value, positive=True, noun="a number of seconds")


@contextlib.contextmanager
def time_budget(seconds: float, what: str, hint: str, writes: bool = True):
    """Within the block, :func:`check_time` raises once ``seconds`` have passed. ``what`` names
    the work ("exporting at 100000 Hz"), ``hint`` how to make it cheaper; ``writes``: the work
    would write a file (the error then says that nothing was written).

    Parameters
    ----------
    seconds : float
        The budget [s].
    what : str
        The work, as the error names it.
    hint : str
        How to make the work cheaper, as the error suggests it.
    writes : bool, optional
        Whether the work would write a file.

    Yields
    ------
    None
        Control to the block.
    """
    token = _DEADLINE.set((time.monotonic() + seconds, seconds, what, hint, "; nothing was written" if writes else ""))
    try:
        yield
    finally:
        _DEADLINE.reset(token)


def active_budget() -> tuple[float, str, str, str] | None:
    """(seconds, what, hint, tail) of the enclosing :func:`time_budget`, None outside one.

    Returns
    -------
    tuple or None
        ``(seconds [s], what, hint, tail)``, or None outside a budget.
    """
    d = _DEADLINE.get()
    return None if d is None else (d[1], d[2], d[3], d[4])


def check_time() -> None:
    """Raise when the enclosing :func:`time_budget` is spent (no-op outside one)."""
    d = _DEADLINE.get()
    if d is not None and time.monotonic() > d[0]:
        _deadline, seconds, what, hint, tail = d
        raise ConfigError(FIELD, f"{what} exceeded the time budget of {fmt_num(seconds)} s and was stopped ({hint}, or "
                                 f"raise `{FIELD}`){tail}")


EIG_PROBE = 256  # larger problems are timed at this size and scaled by (n / EIG_PROBE)³


@one_blas_thread
def eig_seconds(n: int, repeats: int = 3) -> float:
    """Measured seconds of one dense eigenvalue problem of size ``n`` on this machine (median),
    with one BLAS thread as in the sampled-data analysis. Above ``EIG_PROBE`` states it is timed
    at that size and scaled by the cube of the size ratio (the QR algorithm's cost), so that
    estimating the cost of a huge loop does not itself take minutes (three 4 000-state problems
    took 100 s before the budget refused them).

    Parameters
    ----------
    n : int
        Size of the (dense, real) matrix.
    repeats : int, optional
        Number of timings to take the median of.

    Returns
    -------
    float
        Seconds [s] of one eigenvalue problem.
    """
    m = min(int(n), EIG_PROBE)
    rng = np.random.default_rng(0)
    a = rng.standard_normal((m, m))
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        np.linalg.eigvals(a)
        ts.append(time.perf_counter() - t)
    return float(np.median(ts)) * (n / m) ** 3 if m > 0 else 0.0


def refuse_if_over(problems: int, states: int, seconds: float, what: str, hint: str, tail: str = "") -> float:
    """Refuse, before starting, work of at least ``problems`` eigenvalue problems of size
    ``states`` whose measured cost exceeds ``seconds``. Returns the estimate [s].

    Parameters
    ----------
    problems : int
        Lower bound of the number of eigenvalue problems the work solves.
    states : int
        Size of each problem (states of the loop matrix).
    seconds : float
        The time budget [s].
    what : str
        The work, as the error names it.
    hint : str
        How to make the work cheaper.
    tail : str, optional
        Text appended to the error (e.g. "; nothing was written").

    Returns
    -------
    float
        The estimated time [s].

    Raises
    ------
    exotune.errors.ConfigError
        When the estimate exceeds ``seconds``.
    """
    est = problems * eig_seconds(states)
    if est > seconds:
        raise ConfigError(FIELD, f"{what} needs at least {problems} eigenvalue problems of a {states}-state loop "
                                 f"matrix, about {fmt_num(est, 2)} s on this machine, over the time budget of "
                                 f"{fmt_num(seconds)} s ({hint}, or raise `{FIELD}`){tail}")
    return est
