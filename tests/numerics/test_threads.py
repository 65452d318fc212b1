"""exotune.numerics.threads: one_blas_thread limits BLAS to one thread during the call only."""

import numpy as np
import pytest
from threadpoolctl import threadpool_info

from exotune.numerics.threads import one_blas_thread


def _blas_threads():
    return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]


def test_one_thread_inside_restored_after():
    np.linalg.eigvals(np.eye(3))  # BLAS loaded
    before = _blas_threads()
    if not before:
        pytest.skip("no BLAS thread pool visible to threadpoolctl")
    seen = []

    @one_blas_thread
    def work(a, *, b):
        seen.extend(_blas_threads())
        return a + b

    assert work(2, b=3) == 5
    assert seen and set(seen) == {1}
    assert _blas_threads() == before


def test_restored_after_an_exception_and_wraps_keeps_the_name():
    np.linalg.eigvals(np.eye(3))
    before = _blas_threads()

    @one_blas_thread
    def fails():
        """Doc."""
        raise ValueError("boom")

    with pytest.raises(ValueError, match="boom"):
        fails()
    assert _blas_threads() == before
    assert fails.__name__ == "fails" and fails.__doc__ == "Doc."
