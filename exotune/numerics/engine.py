"""The one switch between the compiled (numba) kernels and the numpy reference engine.

``EXOTUNE_NUMPY_ONLY=1`` (or numba missing) selects numpy everywhere; both engines give the same
verdicts (the tests compare them with relative tolerances). Work on a single design runs inside
:func:`numpy_engine`: compiling the kernels (about half a minute on a fresh machine) pays only for
batches, so ``exotune design/analyze/export/certify/simulate`` never wait on the JIT
(docs/architecture.md#engines); the one exception is a large batch of counts inside single-design
work, which loads the kernels when they are already cached (:func:`cached_engine`). Sweeps and
optimization use the compiled kernels; the command line says so once while they compile for the
first time (:func:`kernels_cached`).
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import os
from pathlib import Path

__all__ = ["compiled", "resolve_engine", "numpy_engine", "kernels_cached", "worth_compiling", "cached_engine"]

_PREFERRED: contextvars.ContextVar[str | None] = contextvars.ContextVar("exotune_engine", default=None)


def resolve_engine(engine: str | None) -> str:
    """``engine`` if given, else "numba" when the compiled kernels are usable (numba installed,
    ``EXOTUNE_NUMPY_ONLY`` unset, not inside :func:`numpy_engine`), else "numpy".

    Parameters
    ----------
    engine : str or None
        ``"numba"``, ``"numpy"``, or None to choose.

    Returns
    -------
    str
        The engine to use.
    """
    if engine is None:
        if _PREFERRED.get() == "numpy" or os.environ.get("EXOTUNE_NUMPY_ONLY"):
            return "numpy"
        engine = "numba" if _numba_available() else "numpy"
    return engine


@functools.cache
def _numba_available() -> bool:
    """Whether numba imports (asked once: the engine is resolved at every stage of a batch)."""
    from . import kernels

    return kernels.AVAILABLE


def worth_compiling(work: float, threshold: float = 5e7) -> bool:
    """Whether a single long job (``work`` ≈ floating-point operations) should use a compiled
    kernel even inside :func:`numpy_engine`: numba installed and allowed (``EXOTUNE_NUMPY_ONLY``
    unset) and the work large enough that a one-time compilation (about a second, cached on disk)
    pays for itself.

    Parameters
    ----------
    work : float
        Estimated floating-point operations of the job.
    threshold : float, optional
        Work above which compiling pays off.

    Returns
    -------
    bool
        Whether to use a compiled kernel.
    """
    if os.environ.get("EXOTUNE_NUMPY_ONLY") or work < threshold:
        return False
    from . import kernels

    return kernels.AVAILABLE


def compiled() -> bool:
    """Whether the compiled (numba) kernels are in use here.

    Returns
    -------
    bool
        True when the numba kernels are in use.
    """
    return resolve_engine(None) == "numba"


@contextlib.contextmanager
def numpy_engine():
    """Run the enclosed work on the numpy engine (single designs: no JIT compilation to wait for).

    Examples
    --------
    >>> with numpy_engine():
    ...     compiled()
    False
    """
    token = _PREFERRED.set("numpy")
    try:
        yield
    finally:
        _PREFERRED.reset(token)


def kernels_cached() -> bool:
    """Whether compiled kernels for this machine are already in numba's on-disk cache (beside the
    kernel modules, or under ``NUMBA_CACHE_DIR``); False when numba is not in use.

    Returns
    -------
    bool
        True when the kernels' cache files exist.
    """
    if not compiled():
        return False
    return _cache_present()


def _cache_present() -> bool:
    env = os.environ.get("NUMBA_CACHE_DIR")
    # numba keeps its cache under NUMBA_CACHE_DIR when set, else beside the kernel modules
    place = Path(env) if env else Path(__file__).resolve().parent / "kernels" / "__pycache__"
    return place.is_dir() and any(place.rglob("phase.*.nbi"))


def cached_engine(work: float, threshold: float = 2e3) -> str | None:
    """The engine for one large batch of root counts inside single-design work: "numba" when the
    compiled kernels are allowed (numba installed, ``EXOTUNE_NUMPY_ONLY`` unset) and already in
    the on-disk cache (loading them takes about a second; compiling them is never waited for
    here), and the batch holds at least ``threshold`` counts; else None (the engine in force).

    Parameters
    ----------
    work : float
        Number of counts in the batch.
    threshold : float, optional
        Smallest batch worth loading the kernels for.

    Returns
    -------
    str or None
        "numba" or None.
    """
    if os.environ.get("EXOTUNE_NUMPY_ONLY") or work < threshold or not _cache_present():
        return None
    from . import kernels

    return "numba" if kernels.AVAILABLE else None
