"""exotune.numerics.statespace.tf2ss against scipy.signal.tf2ss (the realization it replaces, for
import time only): the same controllable canonical arrays on random proper transfer functions —
strictly proper, biproper, pure gains, numerators with leading zeros or tiny leading coefficients,
denominators with leading zeros — and the same refusals."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.numerics.statespace import tf2ss

COEF = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
NONZERO = COEF.filter(lambda x: abs(x) > 1e-6)


def _scipy(num, den):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scipy.signal.BadCoefficients)
        return scipy.signal.tf2ss(num, den)


def _same(num, den):
    mine, ref = tf2ss(num, den), _scipy(num, den)
    for a, b, name in zip(mine, ref, "ABCD"):
        assert a.shape == b.shape, (name, a.shape, b.shape)
        np.testing.assert_array_equal(a, b, err_msg=name)
    return mine


@st.composite
def proper(draw):
    """(num, den) of a proper transfer function: den of degree n with a non-zero leading
    coefficient (sometimes after leading zeros), num of degree ≤ n (sometimes padded with zeros,
    exact or below scipy's 1e-14 threshold)."""
    n = draw(st.integers(0, 8))
    den = [draw(NONZERO)] + draw(st.lists(COEF, min_size=n, max_size=n))
    m = draw(st.integers(0, n))
    num = draw(st.lists(COEF, min_size=m + 1, max_size=m + 1))
    pad = draw(st.integers(0, n - m))
    num = [draw(st.sampled_from([0.0, 1e-15, -5e-15])) for _ in range(pad)] + num
    den = [0.0] * draw(st.integers(0, 2)) + den
    return np.array(num), np.array(den)


@settings(max_examples=400, deadline=None)
@given(proper())
def test_the_realization_is_scipys(tf):
    num, den = tf
    _same(num, den)


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 6), st.data())
def test_biproper_and_pure_gain(n, data):
    den = [data.draw(NONZERO)] + data.draw(st.lists(COEF, min_size=n, max_size=n))
    num = [data.draw(NONZERO)] + data.draw(st.lists(COEF, min_size=n, max_size=n))
    _same(num, den)
    _same([data.draw(COEF)], [data.draw(NONZERO)])  # a gain: zero 1×1 A, B, C
    _same([data.draw(COEF)], den)  # constant numerator over degree n


def test_shapes_and_values_of_a_known_case():
    A, B, C, D = _same([1.0, 3.0, 3.0], [1.0, 2.0, 1.0])
    assert A.tolist() == [[-2.0, -1.0], [1.0, 0.0]] and B.tolist() == [[1.0], [0.0]]
    assert C.tolist() == [[1.0, 2.0]] and D.tolist() == [[1.0]]
    A, B, C, D = _same([0.0, 0.0, 2.0], [2.0, 4.0, 8.0])  # leading zeros: strictly proper
    assert C.tolist() == [[0.0, 1.0]] and D.tolist() == [[0.0]]
    _same([0, 1], [1, 2])  # integers
    _same([0.0, 0.0], [1.0, 1.0])  # a zero numerator keeps one coefficient
    for a, b in zip(tf2ss([], [1.0, 2.0]), _scipy([], [1.0, 2.0])):
        assert a.size == b.size == 0


@pytest.mark.parametrize("num, den", [([1.0, 2.0, 3.0], [1.0, 1.0]), ([1.0], [0.0, 0.0]), ([[1.0]], [1.0]),
                                      ([1.0], [[1.0, 2.0]])])
def test_refusals(num, den):
    with pytest.raises(ValueError):
        tf2ss(num, den)
    if np.ndim(num) == 1:  # scipy takes a 2-D numerator (several outputs); tf2ss only one
        with pytest.raises(ValueError):
            _scipy(num, den)
