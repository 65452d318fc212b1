"""exotune.analysis.brackets: the zeros of |qa/qb|² − c and of a family's crossing function on
sign-change brackets, compiled and numpy, against closed forms (the −3 dB points of a second-order
resonance from numpy.roots) and each other."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.analysis.brackets import pair_roots, pair_values
from exotune.numerics.engine import numpy_engine
from exotune.numerics.quasipoly import QP

W0 = np.array([10.0, 50.0, 200.0])
ZETA = np.array([0.05, 0.1, 0.3])
C = np.array([2.0, 4.0, 1.5])  # levels |a/b|² = c above the DC value 1: two crossings each


def _resonance():
    n = W0.size
    qa = QP((W0**2)[:, None], np.zeros((n, 1)), 0.0)
    qb = QP(np.stack([W0**2, 2 * ZETA * W0, np.ones(n)], axis=1), np.zeros((n, 1)), 0.0)
    return qa, qb


def _mag(qa, qb):
    def fun(task, w):
        return np.abs(qa.eval(task, w, deriv=False)[0] / qb.eval(task, w, deriv=False)[0]) ** 2 - C[task]

    return fun


def _closed_form():
    """|b(jω)|² = ω0⁴/c: (x − ω0²)² + 4ζ²ω0² x = ω0⁴/c in x = ω²."""
    out = []
    for w0, z, c in zip(W0, ZETA, C):
        x = np.roots([1.0, 4 * z**2 * w0**2 - 2 * w0**2, w0**4 - w0**4 / c])
        out.append(np.sort(np.sqrt(x.real)))
    return np.array(out)


@pytest.mark.parametrize("engine", ["default", "numpy"])
def test_magnitude_level_crossings_equal_the_closed_form(engine):
    qa, qb = _resonance()
    fun = _mag(qa, qb)
    ref = _closed_form()
    task = np.repeat(np.arange(W0.size), 2)
    a = np.stack([0.5 * ref[:, 0], 0.5 * (ref[:, 0] + ref[:, 1])], axis=1).ravel()
    b = np.stack([0.5 * (ref[:, 0] + ref[:, 1]), 2.0 * ref[:, 1]], axis=1).ravel()
    ctx = numpy_engine() if engine == "numpy" else __import__("contextlib").nullcontext()
    with ctx:
        fa = pair_values(fun, qa, qb, "mag", task, a, c=C)
        fb = pair_values(fun, qa, qb, "mag", task, b, c=C)
        assert np.all(np.sign(fa) != np.sign(fb))
        np.testing.assert_allclose(fa, fun(task, a), rtol=1e-12)
        got = pair_roots(fun, qa, qb, "mag", task, a, b, fa, fb, c=C)
    np.testing.assert_allclose(got, ref.ravel(), rtol=1e-10)


def test_crossing_roots_agree_between_the_engines():
    """g(ω) = Im[Δa · conj(f (jω)² Δb)] of a delayed pair: the compiled and numpy refinements of
    the same brackets find the same zeros, where g vanishes."""
    rng = np.random.default_rng(0)
    n = 4
    T = rng.uniform(1e-3, 5e-3, n)
    qa = QP(np.abs(rng.normal(size=(n, 4))) + 0.1, rng.normal(size=(n, 2)), T)
    qb = QP(np.abs(rng.normal(size=(n, 3))) + 0.1, rng.normal(size=(n, 2)), T)
    f = -1.0

    def g(task, w):
        a = qa.eval(task, w, deriv=False)[0]
        b = qb.eval(task, w, deriv=False)[0]
        return np.imag(a * np.conj(f * (1j * w) ** 2 * b))

    w = np.logspace(-1, 3, 300)
    task, lo, hi = [], [], []
    for t in range(n):
        v = g(np.full(w.size, t), w)
        i = np.nonzero(np.sign(v[:-1]) != np.sign(v[1:]))[0]
        task += [t] * i.size; lo += list(w[i]); hi += list(w[i + 1])
    task, lo, hi = np.array(task), np.array(lo), np.array(hi)
    assert task.size >= 3
    fa, fb = g(task, lo), g(task, hi)
    fast = pair_roots(g, qa, qb, "cross", task, lo, hi, fa, fb, k=2, factor=f)
    with numpy_engine():
        slow = pair_roots(g, qa, qb, "cross", task, lo, hi, fa, fb, k=2, factor=f)
    np.testing.assert_allclose(fast, slow, rtol=1e-10)
    assert np.all((fast >= lo) & (fast <= hi))
    # a zero of g: |g| tiny against the size of its terms
    scale = np.abs(qa.eval(task, fast, deriv=False)[0] * qb.eval(task, fast, deriv=False)[0]) * fast**2
    assert np.all(np.abs(g(task, fast)) <= 1e-9 * scale)
