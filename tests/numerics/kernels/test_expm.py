"""The compiled matrix exponential (exotune.numerics.kernels.expm) against scipy.linalg.expm (what
exotune.sampled.batch.expm_stack runs on the numpy engine) and an mpmath reference, over the norms
the zero-order holds meet (no scaling, up to tens of squarings; badly scaled plant blocks), and
its refusals."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.numerics.engine import numpy_engine
from exotune.numerics.kernels import AVAILABLE
from exotune.sampled.batch import expm_stack

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed: the numpy reference runs")


def _kernel(M):
    from exotune.numerics.kernels.expm import expm_stack as compiled_expm

    return compiled_expm(np.asarray(M, float))


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 9), seed=st.integers(0, 2**31 - 1), log_norm=st.floats(-6, 3))
def test_kernel_equals_the_numpy_reference_and_scipy(n, seed, log_norm):
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((3, n, n))
    M *= 10.0 ** log_norm / np.abs(M).sum(axis=1).max(axis=1)[:, None, None]
    E, ok = _kernel(M)
    assert ok.all()
    grow = max(1.0, 10.0 ** log_norm)  # rounding grows with the norm (the squarings)
    for k in range(3):
        want = scipy.linalg.expm(M[k])
        # norm-wise (e^M of a large random matrix has entries of very different sizes)
        assert np.abs(E[k] - want).max() <= 1e-13 * grow * np.abs(want).max()


@pytest.mark.parametrize("norm", [1e-9, 0.0149, 0.0151, 0.25, 0.26, 0.95, 0.96, 5.0, 40.0])
def test_every_pade_degree_is_exact_to_rounding(norm):
    """Norms on either side of θ3, θ5 and θ7 (degrees 3, 5, 7) and beyond (13 with scaling):
    against scipy on a normal matrix (whose exponential is well conditioned), norm-wise 1e-14
    (times the squarings' growth)."""
    from exotune.numerics.kernels.expm import THETA

    assert THETA[3] < 0.0151 and 0.0149 < THETA[3] and THETA[5] < 0.26 and THETA[7] < 0.96
    rng = np.random.default_rng(7)
    Q, _ = np.linalg.qr(rng.standard_normal((6, 6)))
    D = np.diag(rng.uniform(-1.0, 1.0, 6))
    M = Q @ D @ Q.T
    M *= norm / np.abs(M).sum(axis=0).max()
    E, ok = _kernel(M[None])
    assert ok.all()
    want = scipy.linalg.expm(M)
    assert np.abs(E[0] - want).max() <= 1e-14 * max(1.0, norm) * np.abs(want).max()


@pytest.mark.parametrize("Jm, Ks, Bm", [(1e-4, 1e3, 0.01), (1e-6, 1e4, 1e-4), (0.05, 50.0, 1.0)])
def test_zero_order_hold_of_a_badly_scaled_plant_is_accurate(Jm, Ks, Bm):
    """A spring over a light rotor (entries of 1e7 and more next to 1) held over 1 ms: every entry
    of e^{AT} to about 1e-13 relative of the 40-digit mpmath value (without balancing, the
    unbalanced norm's squarings left 1e-8)."""
    mpmath = pytest.importorskip("mpmath")
    A = np.array([[0.0, 1.0, 0.0], [-Ks / Jm, -Bm / Jm, 1.0 / Jm], [0.0, 0.0, 0.0]]) * 1e-3
    E, ok = _kernel(A[None])
    assert ok.all()
    with mpmath.workdps(40):
        want = np.array(mpmath.expm(mpmath.matrix(A.tolist())).tolist(), dtype=float)
    nz = want != 0
    assert np.all(E[0][~nz] == 0)
    assert np.max(np.abs(E[0][nz] - want[nz]) / np.abs(want[nz])) < 1e-12


def test_dispatch_matches_reference_and_handles_degenerate_stacks():
    rng = np.random.default_rng(1)
    M = rng.standard_normal((5, 4, 4)) * 3.0
    with numpy_engine():
        ref = expm_stack(M)
    assert np.allclose(expm_stack(M), ref, rtol=1e-10, atol=1e-13 * np.abs(ref).max())
    E, ok = _kernel(np.zeros((2, 3, 3)))
    assert ok.all() and np.array_equal(E, np.broadcast_to(np.eye(3), (2, 3, 3)))
    assert _kernel(np.zeros((0, 3, 3)))[0].shape == (0, 3, 3)
    bad = np.zeros((2, 2, 2))
    bad[1, 0, 0] = np.nan
    _E, ok = _kernel(bad)
    assert ok.tolist() == [True, False]
