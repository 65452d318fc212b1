"""The one switch between the compiled (numba) kernels and the numpy reference engine.

``EXOTUNE_NUMPY_ONLY=1`` (or numba missing) selects numpy everywhere; both engines give the same
verdicts (the tests compare them with relative tolerances).
"""

from __future__ import annotations

import os

__all__ = ["compiled", "resolve_engine"]


def resolve_engine(engine: str | None) -> str:
    """``engine`` if given, else "numba" when the compiled kernels are usable, else "numpy"."""
    from . import kernels

    if engine is None:
        engine = "numba" if (kernels.AVAILABLE and not os.environ.get("EXOTUNE_NUMPY_ONLY")) else "numpy"
    return engine


def compiled() -> bool:
    """Whether the compiled (numba) kernels are in use (numba installed, EXOTUNE_NUMPY_ONLY unset)."""
    return resolve_engine(None) == "numba"
