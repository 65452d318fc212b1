"""exotune.numerics.kernels.bounds: the compiled tail bound ω_max, the family tail frequency and the
batched polynomial product, against their definitions (the tail inequalities of
exotune.numerics.quasipoly's docstring evaluated on a dense tail, np.convolve) and the numpy
reference."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.numerics.kernels import AVAILABLE, bounds
from exotune.numerics.quasipoly import omega_max as omega_max_ref

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed")
P = np.polynomial.polynomial


def _rows(rng, n, m0, m1):
    p0 = rng.normal(size=(n, m0)) * 10.0 ** rng.integers(-3, 3, size=(n, m0))
    p1 = rng.normal(size=(n, m1)) * 10.0 ** rng.integers(-3, 3, size=(n, m1))
    return p0, p1


def test_omega_max_satisfies_the_tail_inequalities():
    """For every ω ≥ ω_max: |Σ_{k<n} c_k (jω)^k| ≤ ¼|c_n ω^n| and |P1(jω)| ≤ ¼|P0(jω)|, so Δ has
    no zero on the tail (checked on 200 frequencies from ω_max to 10⁴ ω_max)."""
    rng = np.random.default_rng(0)
    p0, p1 = _rows(rng, 60, 6, 4)
    wm = bounds.omega_max(p0, p1)
    assert np.isfinite(wm).all() and (wm > 0).all()
    w = wm[:, None] * np.logspace(0, 4, 200)[None, :]
    for r in range(p0.shape[0]):
        s = 1j * w[r]
        lead = np.abs(p0[r, -1]) * w[r] ** 5
        low = np.abs(P.polyval(s, p0[r, :-1]))
        assert np.all(low <= 0.25 * lead * (1 + 1e-12))
        assert np.all(np.abs(P.polyval(s, p1[r])) <= 0.25 * np.abs(P.polyval(s, p0[r])) * (1 + 1e-12))


def test_omega_max_is_infinite_where_no_tail_bound_holds():
    p0 = np.array([[1.0, 2.0, 1.0], [1.0, 2.0, 0.0], [0.0, 0.0, 0.0]])
    p1 = np.array([[1.0, 0.5, 0.0], [1.0, 0.5, 0.0], [1.0, 0.0, 0.0]])  # row 1: deg P1 = deg P0 (neutral)
    wm = bounds.omega_max(p0, p1)
    assert np.isfinite(wm[0]) and np.isinf(wm[1]) and np.isinf(wm[2])


@pytest.mark.parametrize("frac", [0.1, 0.25, 0.5])
def test_omega_max_equals_the_numpy_reference(frac):
    rng = np.random.default_rng(4)
    p0, p1 = _rows(rng, 300, 8, 5)
    p0[::9, -1] = 0.0  # degree drops
    got = bounds.omega_max(p0, p1, frac)
    ref = omega_max_ref(p0, p1, frac, engine="numpy")
    np.testing.assert_array_equal(np.isinf(got), np.isinf(ref))
    f = np.isfinite(ref)
    np.testing.assert_allclose(got[f], ref[f], rtol=1e-13, atol=0)


def test_pmul_rows_is_the_row_by_row_product():
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=(50, 5)), rng.normal(size=(50, 3))
    got = bounds.pmul_rows(a, b)
    assert got.shape == (50, 7)
    ref = np.stack([np.convolve(x, y) for x, y in zip(a, b)])
    np.testing.assert_allclose(got, ref, rtol=1e-13, atol=1e-14)


def test_family_wmax_bounds_the_tail_of_every_member():
    """Δa + p·f·φ·Δb for p sampled in [lo, hi]: beyond the family tail frequency |P1| < |P0| (no
    zero of any member there)."""
    rng = np.random.default_rng(5)
    n = 20
    p0a = np.abs(rng.normal(size=(n, 5))) + 0.1
    p1a = rng.normal(size=(n, 3))
    p0b = np.abs(rng.normal(size=(n, 3))) + 0.1
    p1b = rng.normal(size=(n, 2))
    phi = np.array([0.0, 0.0, 1.0])  # φ(s) = s²: the mass slot
    lo, hi = 0.01, 2.0
    W = bounds.family_wmax(p0a, p1a, p0b, p1b, phi, 1.0, lo, hi)
    assert np.isfinite(W).all() and (W > 0).all()
    for r in range(n):
        w = W[r] * np.logspace(0, 4, 100)
        s = 1j * w
        for p in np.linspace(lo, hi, 9):
            P0 = P.polyval(s, p0a[r]) + p * s**2 * P.polyval(s, p0b[r])
            P1 = P.polyval(s, p1a[r]) + p * s**2 * P.polyval(s, p1b[r])
            assert np.all(np.abs(P1) < np.abs(P0)), (r, p)
