"""exotune.numerics.kernels: Horner's rule over a row's nonzero coefficients only (rows padded to a
batch's width, as the root counts receive them). The trimmed evaluation against the numpy reference
(QP.eval) and, bit for bit, against the full-width recurrence; the counts of padded rows against
numpy.roots (polynomials) and the closed-form critical delay of s + a + b e^{−sT} (Hayes)."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.numerics.kernels import AVAILABLE, common, phase
from exotune.numerics.quasipoly import ARG_STEP, DER_STEP, MAX_LEVELS, QP

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed")
KW = dict(arg_step=ARG_STEP, der_step=DER_STEP, max_levels=MAX_LEVELS)


def _pad(c, width):
    return np.pad(c, ((0, 0), (0, width - c.shape[1])))


def _count(P0, P1, T):
    n = P0.shape[0]
    return phase.count_tasks(P0, P1, np.asarray(T, float), np.zeros((n, 1)), np.zeros((n, 1)), np.zeros(n, bool), **KW)


@pytest.mark.parametrize("dtype", [float, complex])
def test_trimmed_evaluation_equals_the_full_width_recurrence_and_the_reference(dtype):
    rng = np.random.default_rng(3)
    n, deg0, deg1, width = 6, 7, 4, 13
    p0 = rng.normal(size=(n, deg0 + 1)).astype(dtype)
    p1 = rng.normal(size=(n, deg1 + 1)).astype(dtype)
    if dtype is complex:
        p0 = p0 + 1j * rng.normal(size=p0.shape)
    c0, c1 = _pad(p0, width), _pad(p1, width)
    T = 2e-3
    w = np.r_[0.0, np.geomspace(1e-3, 1e4, 40)]
    ref_v, ref_d = QP(p0, p1, np.full(n, T)).eval(np.repeat(np.arange(n), w.size), np.tile(w, n))
    for t in range(n):
        m0, m1 = common.row_length(c0, t), common.row_length(c1, t)
        assert (m0, m1) == (deg0 + 1, deg1 + 1)
        for i, x in enumerate(w):
            v, d = common.eval_quasi_n(c0, c1, t, T, x, m0, m1)
            vf, df = common.eval_quasi(c0, c1, t, T, x)
            assert v == vf and d == df  # the skipped steps carry exact zeros
            k = t * w.size + i
            assert abs(v - ref_v[k]) <= 1e-12 * max(abs(ref_v[k]), 1.0)
            assert abs(d - ref_d[k]) <= 1e-12 * max(abs(ref_d[k]), 1.0)


def test_a_zero_row_has_length_one():
    assert common.row_length(np.zeros((2, 5)), 1) == 1
    assert common.row_length(np.array([[0.0, 2.0, 0.0]]), 0) == 2


def test_counts_of_padded_polynomials_equal_numpy_roots():
    """Real polynomials of degrees 2…8 in one batch padded to width 13: the exact number of roots
    with Re s > 0 (numpy.roots of the unpadded polynomial)."""
    rng = np.random.default_rng(5)
    rows, ref = [], []
    for i in range(60):
        deg = 2 + 2 * (i % 4)  # conjugate pairs
        r = rng.normal(size=deg // 2) * rng.choice([1.0, 10.0, 100.0]) + 1j * rng.normal(size=deg // 2) * 20
        p = np.polynomial.polynomial.polyfromroots(np.r_[r, np.conj(r)]).real
        rows.append(p)
        ref.append(int((np.roots(p[::-1]).real > 0).sum()))
    P0 = np.stack([_pad(p[None, :], 13)[0] for p in rows])
    N, rigid, ok = _count(P0, np.zeros((len(rows), 13)), np.zeros(len(rows)))
    assert ok.all()
    np.testing.assert_array_equal(N, ref)
    np.testing.assert_array_equal(rigid, 0)
    assert 0 < np.mean(ref) < 8


def test_counts_of_the_padded_delay_equation_against_its_critical_delay():
    """s + a + b e^{−sT} with b > |a| padded to width 9: stable below T_c = arccos(−a/b)/√(b² − a²),
    two roots in the right half-plane just above; the padded and unpadded rows give the same counts."""
    rng = np.random.default_rng(7)
    m = 24
    b = rng.uniform(1.0, 50.0, m)
    a = b * rng.uniform(-0.9, 0.9, m)
    Tc = np.arccos(-a / b) / np.sqrt(b**2 - a**2)
    P0, P1 = np.stack([a, np.ones(m)], axis=1), b[:, None]
    for f, want in ((0.97, 0), (1.03, 2)):
        N, _, ok = _count(_pad(P0, 9), _pad(P1, 9), f * Tc)
        Nu, _, oku = _count(P0, P1, f * Tc)
        assert ok.all() and oku.all()
        np.testing.assert_array_equal(N, want)
        np.testing.assert_array_equal(N, Nu)
