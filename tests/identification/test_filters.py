"""exotune.identification.filters: the state-variable filter H = ω³/(s + ω)³ and its s-, s²-multiples
against the continuous filter (steady state of a sine, exact step response of a held signal)."""

import math

import numpy as np
import pytest

from exotune.identification.filters import discretization_bound, held_svf, svf, svf_order, velocity_sign

FS, FH = 1000.0, 20.0
W = 2 * math.pi * FH
T = np.arange(0, 3.0, 1 / FS)


def _H(s):
    return W**3 / (s + W) ** 3


def test_sine_steady_state_matches_the_continuous_filter():
    nu = 2 * math.pi * 3.0
    x = np.sin(nu * T)
    outs = svf(x, FS, FH)
    tail = T > 1.0  # the transient (time constant 1/ω ≈ 8 ms) long gone
    for k, y in enumerate(outs):
        g = (1j * nu) ** k * _H(1j * nu)
        ref = np.imag(g * np.exp(1j * nu * T))  # the response to sin = Im(e^{jνt})
        assert np.allclose(y[tail], ref[tail], rtol=0, atol=2e-4 * abs(g)), k
        assert np.array_equal(svf_order(x, FS, FH, k), y)


def test_held_step_is_filtered_exactly():
    u = np.ones(T.size)
    h, sh, s2h = svf(u, FS, FH, hold="zoh")
    wt = W * T
    # step responses of ω³/(s+ω)³, s·…, s²·… (inverse Laplace by hand)
    ref0 = 1 - np.exp(-wt) * (1 + wt + wt**2 / 2)
    ref1 = W * np.exp(-wt) * wt**2 / 2
    ref2 = W**2 * np.exp(-wt) * (wt - wt**2 / 2)
    assert np.allclose(h, ref0, atol=1e-12) and np.allclose(sh, ref1, atol=1e-9 * W)
    assert np.allclose(s2h, ref2, atol=1e-9 * W**2)
    assert np.allclose(held_svf(u, FS, FH), ref0 + ref2 / (12 * FS**2), atol=1e-12)


def test_discretization_bound():
    wt = 2 * math.pi * FH / FS
    assert discretization_bound(FS, FH) == pytest.approx(4e-3 * wt**3 + 1e-7)
    assert discretization_bound(10 * FS, FH) < discretization_bound(FS, FH)


def test_velocity_sign_follows_the_derivative():
    theta = np.sin(2 * math.pi * 1.0 * T) + 1e-7 * np.random.default_rng(0).normal(size=T.size)
    sgn = velocity_sign(theta, FS, FH)
    ref = np.sign(np.cos(2 * math.pi * 1.0 * T))
    away = np.abs(np.cos(2 * math.pi * 1.0 * T)) > 0.05  # away from the turning points
    assert np.array_equal(sgn[away], ref[away])
    assert set(np.unique(sgn)) <= {-1.0, 0.0, 1.0}
