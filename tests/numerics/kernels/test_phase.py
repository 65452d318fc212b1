"""exotune.numerics.kernels.phase: the compiled argument-principle count. Root counts of ordinary
polynomials against numpy.roots, of the delay equation s + a + b e^{−sT} against its closed-form
critical delay (Hayes: for b > |a| stable exactly while T < arccos(−a/b)/√(b² − a²), two roots
cross at once), and the phase sums against the numpy reference (quasipoly.phase_sums)."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.numerics.kernels import AVAILABLE, phase
from exotune.numerics.quasipoly import ARG_STEP, DER_STEP, MAX_LEVELS, QP, log_grid, omega_max
from exotune.numerics.quasipoly import phase_sums as phase_sums_ref

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed")
KW = dict(arg_step=ARG_STEP, der_step=DER_STEP, max_levels=MAX_LEVELS)


def _count(P0, P1, T):
    n = P0.shape[0]
    return phase.count_tasks(P0, P1, np.asarray(T, float), np.zeros((n, 1)), np.zeros((n, 1)), np.zeros(n, bool), **KW)


def test_counts_of_polynomials_equal_numpy_roots():
    """Random real polynomials (P1 ≡ 0, no delay): the exact number of roots with Re s > 0."""
    rng = np.random.default_rng(0)
    n = 80
    roots = rng.normal(size=(n, 6)) * np.array([1, 1, 3, 3, 10, 10]) + 1j * rng.normal(size=(n, 6)) * 5
    roots[:, 1::2] = np.conj(roots[:, ::2])  # conjugate pairs: real coefficients
    P0 = np.stack([np.polynomial.polynomial.polyfromroots(r).real for r in roots])
    ref = np.array([(np.roots(p[::-1]).real > 0).sum() for p in P0])
    N, rigid, ok = _count(P0, np.zeros((n, 1)), np.zeros(n))
    assert ok.all()
    np.testing.assert_array_equal(N, ref)
    np.testing.assert_array_equal(rigid, 0)
    assert 0 < ref.mean() < 6  # both stable and unstable rows


def test_exact_roots_at_the_origin_are_stripped_and_counted():
    """s²·(s − 2)(s + 3): two rigid-body roots, one RHP root."""
    p = np.polynomial.polynomial.polyfromroots([0.0, 0.0, 2.0, -3.0]).real
    N, rigid, ok = _count(p[None, :], np.zeros((1, 1)), [0.0])
    assert ok[0] and N[0] == 1 and rigid[0] == 2


def test_counts_of_the_delay_equation_against_its_critical_delay():
    rng = np.random.default_rng(1)
    m = 30
    b = rng.uniform(1.0, 50.0, m)
    a = b * rng.uniform(-0.9, 0.9, m)
    Tc = np.arccos(-a / b) / np.sqrt(b**2 - a**2)
    P0 = np.stack([a, np.ones(m)], axis=1)
    P1 = b[:, None]
    N_below, _, ok_below = _count(P0, P1, 0.97 * Tc)
    N_above, _, ok_above = _count(P0, P1, 1.03 * Tc)
    assert ok_below.all() and ok_above.all()
    np.testing.assert_array_equal(N_below, 0)
    np.testing.assert_array_equal(N_above, 2)
    # a ≥ |b|: stable for every delay
    N, _, ok = _count(np.array([[5.0, 1.0]]), np.array([[4.0]]), [3.0])
    assert ok[0] and N[0] == 0


def test_phase_sums_equal_the_numpy_reference():
    rng = np.random.default_rng(3)
    n = 40
    p0 = rng.normal(size=(n, 6))
    p0[:, -1] = np.abs(p0[:, -1]) + 0.5
    p1 = rng.normal(size=(n, 4)) * 0.5
    p0[0, -2:] = 0.0  # deg P0 = deg P1: not retarded, no tail bound
    T = rng.uniform(0.0, 0.05, n)
    q = QP(p0, p1, T)
    wm = omega_max(p0, p1, engine="numpy")
    valid = np.isfinite(wm)
    grid = log_grid(np.where(valid, wm, 1.0), decades=6, per_decade=2)
    tot, res, cnt = phase.phase_sums(p0, p1, T, grid, valid, **KW)
    tot_ref, res_ref = phase_sums_ref(q, grid, valid, engine="numpy")
    np.testing.assert_array_equal(res[valid], res_ref[valid])  # (tasks not summed: no verdict)
    ok = res & valid
    assert ok.sum() > n // 2 and not valid[0]
    np.testing.assert_allclose(tot[ok], tot_ref[ok], rtol=0, atol=1e-9)
    assert (cnt[valid] >= grid.shape[1]).all()  # every grid point evaluated at least
    assert (cnt[~valid] == 0).all() and (tot[~valid] == 0).all()
