"""exotune.numerics.kernels.common: the coefficient layout of the kernels and the inlined scalar
primitives (Horner's rule at s = jω in real arithmetic, Δ(jω) and its derivative, the complex
division that never raises, the log-derivative, the interval acceptance rule) against the numpy
reference (exotune.numerics.quasipoly.QP.eval) and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from exotune.numerics import budgets
from exotune.numerics.kernels import common
from exotune.numerics.quasipoly import QP, ARG_STEP, DER_STEP

needs_numba = pytest.mark.skipif(not common.AVAILABLE, reason="numba not installed")


def test_budgets_are_the_numerics_budgets():
    assert common.MAX_TASK_EVALS == budgets.MAX_TASK_EVALS
    assert common.MAX_TASK_LEAVES == budgets.MAX_TASK_LEAVES
    assert common.MAX_GROUP_EVALS == budgets.MAX_GROUP_EVALS
    assert common.GEO_SPLIT_RATIO == budgets.GEO_SPLIT_RATIO


@pytest.mark.parametrize("cplx0,cplx1", [(False, False), (True, False), (False, True)])
def test_coefficients_take_a_common_contiguous_dtype(cplx0, cplx1):
    rng = np.random.default_rng(1)
    p0 = rng.normal(size=(4, 9))[:, ::2]  # a non-contiguous view
    p1 = rng.normal(size=(4, 3))
    if cplx0:
        p0 = p0 + 1j
    if cplx1:
        p1 = p1 * (1 + 2j)
    c0, c1 = common.coefficients(QP(p0, p1, 1e-3))
    want = complex if (cplx0 or cplx1) else float
    assert c0.dtype == want and c1.dtype == want
    assert c0.flags.c_contiguous and c1.flags.c_contiguous
    np.testing.assert_array_equal(c0, p0)
    np.testing.assert_array_equal(c1, p1)


@needs_numba
@pytest.mark.parametrize("cplx", [False, True])
def test_eval_quasi_equals_the_numpy_value_and_derivative(cplx):
    rng = np.random.default_rng(7 + cplx)
    n = 20
    p0 = rng.normal(size=(n, 6))
    p1 = rng.normal(size=(n, 4))
    if cplx:
        p0 = p0 + 1j * rng.normal(size=p0.shape)
        p1 = p1 + 1j * rng.normal(size=p1.shape)
    T = rng.uniform(0.0, 0.01, n)
    q = QP(p0, p1, T)
    c0, c1 = common.coefficients(q)
    w = np.exp(rng.uniform(np.log(0.1), np.log(300.0), n))
    ref_v, ref_d = q.eval(np.arange(n), w)
    for t in range(n):
        v, d = common.eval_quasi(c0, c1, t, T[t], w[t])
        assert v == pytest.approx(ref_v[t], rel=1e-12)
        assert d == pytest.approx(ref_d[t], rel=1e-12)
        # horner alone: P0(jω) and P0'(jω)
        vr, vi, dr, di = common.horner(c0, t, w[t])
        s = 1j * w[t]
        assert complex(vr, vi) == pytest.approx(np.polynomial.polynomial.polyval(s, p0[t]), rel=1e-12)
        assert complex(dr, di) == pytest.approx(
            np.polynomial.polynomial.polyval(s, np.polynomial.polynomial.polyder(p0[t])), rel=1e-12)


@needs_numba
def test_cdiv_never_raises_and_otherwise_divides():
    assert common.cdiv(3 + 4j, 1 - 2j) == pytest.approx((3 + 4j) / (1 - 2j), rel=1e-15)
    z = common.cdiv(1 + 0j, 0j)
    assert math.isinf(z.real)
    z = common.cdiv(0j, 0j)
    assert math.isnan(z.real) and math.isnan(z.imag)


@needs_numba
@pytest.mark.parametrize("v", [2 - 1j, 1e-160 + 3e-160j, 1e200 - 1e200j])
def test_log_derivative_is_the_quotient(v):
    d = 0.3 + 0.7j
    assert common.log_derivative(d * abs(v), v) == pytest.approx(d * abs(v) / v, rel=1e-13)
    assert common.log_derivative(d, 0j) == 0j


@needs_numba
def test_interval_acceptance_rule():
    tan_arg = math.tan(ARG_STEP)
    # Δ(s) = s + 1 on [0.1, 0.2]: a small, smooth phase step → accepted, the step is arg(xb/xa)
    f = lambda w: (1 + 1j * w, 1j / (1 + 1j * w))  # (value, log-derivative dΔ/ds / Δ)  # noqa: E731
    (xa, La), (xb, Lb) = f(0.1), f(0.2)
    ok, bad, ang = common.interval_ok(0.1, 0.2, xa, xb, La, Lb, tan_arg, DER_STEP)
    assert ok and not bad and ang == pytest.approx(np.angle(xb / xa), rel=1e-12)
    # a phase step larger than ARG_STEP → split (not accepted, not bad)
    (xa, La), (xb, Lb) = f(0.1), f(100.0)
    ok, bad, _ = common.interval_ok(0.1, 100.0, xa, xb, La, Lb, tan_arg, DER_STEP)
    assert not ok and not bad
    # a zero value (a root on the axis) → bad; a structural zero at ω = 0 → skipped (accepted)
    ok, bad, _ = common.interval_ok(1.0, 2.0, 0j, xb, La, Lb, tan_arg, DER_STEP)
    assert not ok and bad
    ok, bad, ang = common.interval_ok(0.0, 2.0, 0j, xb, La, Lb, tan_arg, DER_STEP)
    assert ok and not bad and ang == 0.0
