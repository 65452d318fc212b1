"""exotune.numerics: the numerical core, the lowest computing layer (docs/architecture.md).

``poly``        batched polynomial and rational-function arithmetic (:class:`Rational`)
``quasipoly``   quasi-polynomials P0 + P1·e^{−sT} and exact right-half-plane root counts
``statespace``  ``tf2ss`` (scipy.signal's realization, without importing scipy.signal)
``engine``      the one switch between the compiled (numba) kernels and the numpy reference
``budgets``     per-task work budgets of the adaptive algorithms
``timebudget``  the time budget of ``exotune export`` and ``exotune certify``
``threads``     one BLAS thread for the small eigenvalue problems
``beside``      one independent computation in a forked child process beside the caller's work
``kernels``     the compiled kernels (numba), imported only by the engines that run them
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "Rational": "poly",
        "QP": "quasipoly",
        "count_rhp": "quasipoly",
        "tf2ss": "statespace",
        "numpy_engine": "engine",
    },
)
