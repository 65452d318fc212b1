"""exotune.numerics.poly: batched polynomial arithmetic against numpy.polynomial and
python-control, exact structural zeros, and the Rational batch."""

import control
import numpy as np
import numpy.polynomial.polynomial as P
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from exotune.numerics.poly import (Rational, as_poly, ascending, degree, descending, leading, padd, pder, pmul,
                                   pscale, psub, pval, pval_flat, strip_common_low_zeros)

coef = st.floats(-10, 10, allow_nan=False)
polys = st.integers(1, 6).flatmap(lambda n: arrays(float, (3, n), elements=coef))


@given(polys, polys)
def test_add_sub_mul_match_numpy_polynomial(a, b):
    n = max(a.shape[1], b.shape[1])
    assert padd(a, b).shape == psub(a, b).shape == (3, n)
    for i in range(3):
        ref_add, ref_sub = P.polyadd(a[i], b[i]), P.polysub(a[i], b[i])  # numpy trims top zeros
        assert np.allclose(padd(a, b)[i, : len(ref_add)], ref_add) and not padd(a, b)[i, len(ref_add):].any()
        assert np.allclose(psub(a, b)[i, : len(ref_sub)], ref_sub) and not psub(a, b)[i, len(ref_sub):].any()
    prod = pmul(a, b)
    assert prod.shape == (3, a.shape[1] + b.shape[1] - 1)
    for i in range(3):
        assert np.allclose(prod[i], np.convolve(a[i], b[i]), rtol=1e-12, atol=1e-9)


def test_pmul_large_batch_matches_convolution():
    """Large real batches may run compiled: same result as the convolution."""
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(200, 5)), rng.normal(size=(200, 4))
    out = pmul(a, b)
    ref = np.array([np.convolve(a[i], b[i]) for i in range(200)])
    assert np.allclose(out, ref, rtol=1e-12, atol=1e-12)


def test_pmul_keeps_structural_zeros_exact():
    # (J s² + B s)(1 + τ s): no constant term, exactly
    a = as_poly(0.0, np.array([0.3, 1e-9]), np.array([1e-4, 2.0]))
    b = as_poly(np.array([1.0, 7.0]), np.array([1e-3, 3.0]))
    assert np.all(pmul(a, b)[:, 0] == 0.0)
    assert np.all(pmul(a, b).dtype == np.float64)


def test_as_poly_broadcasts_and_fixes_shape():
    c = as_poly(1, np.array([2.0, 3.0]), 0)
    assert c.shape == (2, 3) and c.dtype == float
    assert c.tolist() == [[1.0, 2.0, 0.0], [1.0, 3.0, 0.0]]
    d = as_poly(1, 2, shape=(4,))
    assert d.shape == (4, 2) and d.flags.writeable
    assert as_poly(1j, 2).dtype.kind == "c"


@given(polys, st.floats(-3, 3))
def test_pval_and_pder_match_numpy(a, x):
    assert np.allclose(pval(a, np.array([x, 2 * x])), [[P.polyval(x, r), P.polyval(2 * x, r)] for r in a],
                       rtol=1e-9, atol=1e-6)
    d = pder(a)
    ref = [P.polyder(r) if len(r) > 1 else np.zeros(1) for r in a]
    assert np.allclose(d, ref)


def test_pval_complex_and_flat():
    c = np.array([[1.0, 0.0, 1.0], [0.0, 2.0, 0.0]])  # 1 + s², 2 s
    s = np.array([1j, 2j])
    assert np.allclose(pval(c, s), [[0.0, -3.0], [2j, 4j]])
    assert np.allclose(pval_flat(c, np.array([1, 0, 1]), np.array([1j, 2.0, 3.0])), [2j, 5.0, 6.0])


def test_pscale_per_row():
    a = np.array([[1.0, 2.0], [3.0, 4.0]])
    assert pscale(a, 2.0).tolist() == [[2.0, 4.0], [6.0, 8.0]]
    assert pscale(a, np.array([1.0, -1.0])).tolist() == [[1.0, 2.0], [-3.0, -4.0]]


def test_degree_and_leading():
    c = np.array([[1.0, 2.0, 0.0], [0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [0.0, 0.0, -3.0]])
    assert degree(c).tolist() == [1, -1, 0, 2]
    assert leading(c).tolist() == [2.0, 0.0, 5.0, -3.0]


def test_strip_common_low_zeros():
    a = np.array([[0.0, 0.0, 1.0, 2.0], [0.0, 3.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]])
    b = np.array([[0.0, 0.0, 0.0, 4.0], [0.0, 0.0, 5.0, 0.0], [0.0, 6.0, 0.0, 0.0]])
    r, (sa, sb) = strip_common_low_zeros(a, b)
    assert r.tolist() == [2, 1, 0]
    assert sa.tolist() == [[1.0, 2.0, 0.0, 0.0], [3.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
    assert sb.tolist() == [[0.0, 4.0, 0.0, 0.0], [0.0, 5.0, 0.0, 0.0], [0.0, 6.0, 0.0, 0.0]]
    r1, _ = strip_common_low_zeros(a, b, max_strip=1)
    assert r1.tolist() == [1, 1, 0]
    # the zero polynomial divides nothing
    r0, (z,) = strip_common_low_zeros(np.zeros((1, 3)))
    assert r0.tolist() == [0] and z.tolist() == [[0.0, 0.0, 0.0]]


@given(arrays(float, 5, elements=coef))
def test_ascending_descending_round_trip(c):
    d = descending(c)
    nz = np.flatnonzero(c)
    top = nz[-1] if nz.size else 0
    assert d.tolist() == c[: top + 1][::-1].tolist()
    assert ascending(d).tolist() == c[: top + 1].tolist()


def test_descending_drops_leading_zeros_only():
    assert descending([0.0, 1.0, 0.0, 0.0]).tolist() == [1.0, 0.0]
    assert descending([0.0, 0.0]).tolist() == [0.0]


def _tf(num, den):
    return control.TransferFunction(descending(num), descending(den))


def test_rational_algebra_matches_python_control():
    g = Rational(np.array([[1.0, 2.0]]), np.array([[3.0, 1.0, 1.0]]))  # (1+2s)/(3+s+s²)
    h = Rational(np.array([[4.0]]), np.array([[1.0, 0.5]]))  # 4/(1+s/2)
    G, H = _tf([1.0, 2.0], [3.0, 1.0, 1.0]), _tf([4.0], [1.0, 0.5])
    s = 1j * np.array([0.1, 1.0, 7.0])
    for mine, ref in [(g * h, G * H), (g + h, G + H), (g - h, G - H), (-g, -G), (2.0 * g, 2 * G), (g + 1.0, G + 1)]:
        assert np.allclose(mine(s)[0], ref(s), rtol=1e-12)
    assert np.allclose(g.to_control()(s), G(s), rtol=1e-12)
    num, den = g.descending()
    assert num.tolist() == [2.0, 1.0] and den.tolist() == [1.0, 1.0, 3.0]


def test_rational_helpers():
    k = Rational.const(np.array([2.0, 3.0]))
    assert np.allclose(k(np.array([[5j], [7.0]])), [[2.0], [3.0]])
    p = Rational.poly(np.array([[1.0, 1.0]]))
    assert np.allclose(p(np.array([2.0])), [[3.0]])
    r = Rational(np.array([[1.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), np.array([[1.0, 1.0, 0.0]]))
    assert r.is_proper().tolist() == [False, True]
    t = r.take(1)
    assert t.num.tolist() == [1.0, 0.0, 0.0] and t.den.tolist() == [1.0, 1.0, 0.0]
    assert Rational.poly(np.array([1.0, 2.0])).to_control().num[0][0].tolist() == [2.0, 1.0]
    with pytest.raises(Exception):
        r.num = None  # frozen


# --------------------------------------------------------------------- is_hurwitz (exact Routh)
def test_is_hurwitz_on_known_polynomials():
    from exotune.numerics.poly import is_hurwitz

    assert is_hurwitz([6.0, 11.0, 6.0, 1.0])  # (s+1)(s+2)(s+3)
    assert is_hurwitz([-6.0, -11.0, -6.0, -1.0])  # the same, negated
    assert not is_hurwitz([1.0, 1.0, 1.0, 1.0])  # (s+1)(s²+1): roots ±j (a row of zeros in the array)
    assert not is_hurwitz([1.0, 0.0, 1.0])  # s² + 1
    assert not is_hurwitz([0.0, 1.0])  # a root at 0
    assert not is_hurwitz([1.0, -1.0])  # s = 1
    assert is_hurwitz([3.0]) and is_hurwitz([1.0, 0.0])  # a constant (trailing zeros dropped)
    assert not is_hurwitz([1.0, 2.0, 2.0, 1.0, 1.0])  # all positive, roots in Re s > 0


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(-3.0, 3.0), st.floats(0.0, 3.0)), min_size=1, max_size=4),
       st.floats(0.1, 10.0))
def test_is_hurwitz_agrees_with_the_roots(pairs, gain):
    """Polynomials built from known roots, real parts at least 1e-2 away from the axis (the
    coefficients' rounding moves a root far less): Hurwitz exactly when every root has Re < 0."""
    from exotune.numerics.poly import is_hurwitz

    roots = []
    for re, im in pairs:
        re = re if abs(re) >= 1e-2 else (1e-2 if re >= 0 else -1e-2)
        roots += [complex(re, im), complex(re, -im)] if im > 1e-3 else [complex(re, 0.0)]
    c = np.real(np.poly(roots))[::-1] * gain  # ascending
    assert is_hurwitz(c) is all(r.real < 0 for r in roots)
