"""exotune.numerics.kernels.pair: the compiled scalar functions of a pair of quasi-polynomials
(crossing function, magnitude level, passivity phase excess) against their formulas evaluated with
QP.eval, the Illinois roots against the numpy reference (quasipoly.bisect_roots) and the
golden-section maxima against a dense sweep."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.numerics.kernels import AVAILABLE, pair
from exotune.numerics.quasipoly import QP, bisect_roots

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed")


def _pair(seed=0, n=6):
    rng = np.random.default_rng(seed)
    a0 = np.abs(rng.normal(size=(n, 5))) + 0.2
    a1 = rng.normal(size=(n, 3))
    b0 = np.abs(rng.normal(size=(n, 4))) + 0.2
    b1 = rng.normal(size=(n, 2))
    T = rng.uniform(1e-3, 2e-2, n)
    return QP(a0, a1, T), QP(b0, b1, T)


def _ref(qa, qb, mode, task, w, k=0, factor=1.0, c=0.0):
    a = qa.eval(task, w, deriv=False)[0]
    b = qb.eval(task, w, deriv=False)[0]
    if mode == "cross":
        return np.imag(a * np.conj(factor * (1j * w) ** k * b))
    if mode == "mag":
        return np.abs(a / b) ** 2 - np.broadcast_to(c, (qa.n,))[task]
    ph = np.degrees(np.angle(b / a))
    return np.where(ph > 0, np.minimum(ph, 180.0 - ph), 0.0)


@pytest.mark.parametrize("mode,k,factor", [("cross", 0, 1.0), ("cross", 2, -1.0), ("cross", 1, 1 + 0.3j),
                                           ("mag", 0, 1.0), ("excess", 0, 1.0)])
def test_values_equal_their_formula(mode, k, factor):
    qa, qb = _pair()
    rng = np.random.default_rng(1)
    task = rng.integers(0, qa.n, 500)
    w = np.exp(rng.uniform(np.log(0.01), np.log(1e3), 500))
    c = rng.uniform(0.5, 2.0, qa.n)
    got = pair.pair_values(qa, qb, mode, task, w, k=k, factor=factor, c=c)
    ref = _ref(qa, qb, mode, task, w, k, factor, c)
    scale = np.abs(ref).max()
    np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-12 * scale)
    if mode == "excess":
        assert (got >= 0).all() and (got <= 90.0).all() and (got > 0).any()


def _brackets(qa, qb, mode, k=0, factor=1.0, c=None):
    w = np.logspace(-2, 3, 400)
    task, a, b, fa, fb = [], [], [], [], []
    for t in range(qa.n):
        g = pair.pair_values(qa, qb, mode, np.full(w.size, t), w, k=k, factor=factor, c=c)
        i = np.nonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0)[0]
        task += [t] * i.size
        a += list(w[i]); b += list(w[i + 1]); fa += list(g[i]); fb += list(g[i + 1])
    return tuple(np.asarray(x) for x in (task, a, b, fa, fb))


@pytest.mark.parametrize("mode,k,factor", [("cross", 0, 1.0), ("cross", 2, -1.0), ("mag", 0, 1.0)])
def test_roots_equal_the_numpy_illinois_and_are_zeros(mode, k, factor):
    qa, qb = _pair(2)
    c = np.full(qa.n, 1.0)
    task, a, b, fa, fb = _brackets(qa, qb, mode, k, factor, c)
    assert task.size >= qa.n
    got = pair.pair_roots(qa, qb, mode, task, a, b, fa, fb, k=k, factor=factor, c=c)
    assert np.all((got >= a) & (got <= b))
    ref = bisect_roots(lambda t, w: _ref(qa, qb, mode, t, w, k, factor, c), task, a, b, fa, fb=fb)
    np.testing.assert_allclose(got, ref, rtol=1e-10)
    if mode == "cross":
        np.testing.assert_array_equal(pair.refine_crossings(qa, qb, k, factor, task, a, b, fa, fb), got)


def test_golden_max_finds_the_dense_sweep_maximum_of_the_excess():
    qa, qb = _pair(3)
    w = np.logspace(-2, 3, 20001)
    task, lo, hi, dense = [], [], [], []
    for t in range(qa.n):
        v = _ref(qa, qb, "excess", np.full(w.size, t), w)
        i = int(np.argmax(v))
        if v[i] <= 0 or i in (0, w.size - 1):
            continue
        # the interval between the neighbouring sweep points that bracket the peak
        task.append(t); lo.append(w[max(i - 50, 0)]); hi.append(w[min(i + 50, w.size - 1)]); dense.append(v[i])
    assert task
    got = pair.golden_max(qa, qb, "excess", np.array(task), np.array(lo), np.array(hi), iters=60)
    assert np.all(got >= np.array(dense) - 1e-6)
    assert np.all(got <= 90.0)  # the excess never exceeds 90°


def test_golden_max_finds_a_resonance_peak_of_the_magnitude():
    """|a/b|² with b = s² + 2ζω0 s + ω0² and a = ω0²: peak 1/(4ζ²(1 − ζ²)) at ω0√(1 − 2ζ²)."""
    zeta = np.array([0.02, 0.05, 0.2])
    w0 = np.array([10.0, 300.0, 2.0])
    n = zeta.size
    qa = QP((w0**2)[:, None], np.zeros((n, 1)), 0.0)
    qb = QP(np.stack([w0**2, 2 * zeta * w0, np.ones(n)], axis=1), np.zeros((n, 1)), 0.0)
    got = pair.golden_max(qa, qb, "mag", np.arange(n), 0.5 * w0, 1.5 * w0, iters=80)
    np.testing.assert_allclose(got, 1.0 / (4 * zeta**2 * (1 - zeta**2)), rtol=1e-9)
