"""exotune.controllerfile.sos: the prewarped bilinear transform to second-order sections
(:func:`tustin_sos`) against scipy's own bilinear transform of the same block, and the state space
of a cascade (:func:`sos_ss`) against ``scipy.signal.sosfilt`` of the same sections."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.controllerfile.sos import sos_ss, tustin_sos


def _freqresp_s(num_asc, den_asc, w):
    s = 1j * w
    return np.polyval(np.asarray(num_asc)[::-1], s) / np.polyval(np.asarray(den_asc)[::-1], s)


def _freqresp_sos(sos, w, fs):
    _, h = scipy.signal.sosfreqz(sos, worN=[w / (2 * np.pi)], fs=fs)
    return h[0]


def test_unwarped_sections_are_scipy_bilinear():
    fs = 1000.0
    num, den = [4.0, 0.3], [400.0, 20.0, 1.0]  # ascending powers of s
    sos = tustin_sos(num, den, fs)
    b, a = scipy.signal.bilinear(num[::-1], den[::-1], fs)
    impulse = np.zeros(64)
    impulse[0] = 1.0
    np.testing.assert_allclose(scipy.signal.sosfilt(sos, impulse), scipy.signal.lfilter(b, a, impulse),
                               rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("prewarp_hz", [5.0, 60.0, 200.0])
def test_prewarped_response_is_exact_at_the_prewarp_frequency(prewarp_hz):
    fs = 1000.0
    num, den = [142122.3], [142122.3, 527.8, 1.0]  # a second-order low-pass (the DOB's Q)
    sos = tustin_sos(num, den, fs, prewarp_hz)
    w = 2 * math.pi * prewarp_hz
    assert _freqresp_sos(sos, w, fs) == pytest.approx(_freqresp_s(num, den, w), rel=1e-9)
    # and not exact elsewhere (the warping is real): at 400 Hz the plain map differs
    w2 = 2 * math.pi * 400.0
    assert abs(_freqresp_sos(sos, w2, fs) - _freqresp_s(num, den, w2)) > 1e-6 * abs(_freqresp_s(num, den, w2))


def test_dc_gain_is_kept():
    sos = tustin_sos([3.0, 1.0, 0.5], [2.0, 3.0, 1.0], 500.0, 30.0)
    assert np.prod(sos[:, :3].sum(axis=1)) / np.prod(sos[:, 3:].sum(axis=1)) == pytest.approx(1.5, rel=1e-9)


def test_improper_block_is_refused():
    with pytest.raises(ValueError, match="improper"):
        tustin_sos([1.0, 0.0, 1.0], [1.0, 1.0], 1000.0)


def _random_stable_sos(rng, q):
    rows = []
    for _ in range(q):
        r, th = rng.uniform(0.1, 0.95), rng.uniform(0.0, math.pi)
        a1, a2 = -2 * r * math.cos(th), r * r
        rows.append([*rng.normal(size=3), 1.0, a1, a2])
    return np.array(rows)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 4), st.integers(0, 2**32 - 1))
def test_state_space_of_the_cascade_is_sosfilt(q, seed):
    rng = np.random.default_rng(seed)
    sos = _random_stable_sos(rng, q)
    A, B, C, D = sos_ss(sos)
    assert A.shape == (2 * q, 2 * q) and B.shape == (2 * q, 1) and C.shape == (1, 2 * q) and D.shape == (1, 1)
    u = rng.normal(size=50)
    _, y, _ = scipy.signal.dlsim((A, B, C, D, 1.0), u)
    np.testing.assert_allclose(y[:, 0], scipy.signal.sosfilt(sos, u), rtol=1e-9, atol=1e-9)
    # the poles of the state space are the sections' poles
    poles = np.sort_complex(np.concatenate([np.roots(r[3:]) for r in sos]))
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A)), poles, rtol=1e-7, atol=1e-9)


def test_rows_with_a0_not_one_are_normalized():
    sos = np.array([[2.0, 1.0, 0.5, 2.0, -0.4, 0.1]])
    A, B, C, D = sos_ss(sos)
    u = np.r_[1.0, np.zeros(20)]
    _, y, _ = scipy.signal.dlsim((A, B, C, D, 1.0), u)
    np.testing.assert_allclose(y[:, 0], scipy.signal.lfilter(sos[0, :3], sos[0, 3:], u), rtol=1e-12, atol=1e-14)
