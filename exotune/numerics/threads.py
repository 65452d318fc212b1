"""One BLAS thread for the small dense eigenvalue problems of the sampled-data analysis.

The sampled-data loop matrix has one state per sample of delay (a 1 ms delay at 100 kHz: ~120
states). OpenBLAS splits LAPACK's work on such a matrix over all cores, and the threads spend
more time synchronizing than computing: on a 2-core machine one 117-state eigenvalue problem
took 5.2 ms with the default threads and 2.3 ms with one, and ``exotune export`` at 100 kHz
4× longer. :func:`one_blas_thread` limits BLAS to one thread for the duration of a call
(threadpoolctl, restored afterwards, so a caller's own setting is untouched).

References
----------
docs/benchmarks.md (high sample rates).
"""

from __future__ import annotations

import functools

__all__ = ["one_blas_thread"]


def one_blas_thread(fn):
    """Decorator: run ``fn`` with BLAS limited to one thread (threadpoolctl).

    Parameters
    ----------
    fn : callable
        The function to wrap.

    Returns
    -------
    callable
        The wrapped function (same signature and result).
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return wrapper
