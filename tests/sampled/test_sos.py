"""exotune.sampled.sos: the prewarped bilinear transform and the runtime's state space of a cascade,
against scipy.signal (bilinear, sosfilt, sosfreqz) and the continuous response."""

import numpy as np
import pytest
import scipy.signal

from exotune.sampled.sos import (bilinear_batch, df2t_batch, sos_ss, sos_ss_batch, tustin_sections_batch,
                                 tustin_sos)

FS = 1000.0
W = 2 * np.pi * np.array([1.0, 30.0, 120.0, 400.0])  # rad/s, below Nyquist
Z = np.exp(1j * W / FS)
# a proper block (ascending powers of s): (1 + s/50)(1 + s/300) / ((s² + 2·0.3·80 s + 80²)(1 + s/20)), scaled
WN = 2 * np.pi * 40.0
NUM = np.polynomial.polynomial.polymul([1.0, 1 / 50.0], [1.0, 1 / 300.0]) * WN**2
DEN = np.polynomial.polynomial.polymul([WN**2, 2 * 0.3 * WN, 1.0], [1.0, 1 / 20.0])


def _cont(w):
    s = 1j * w
    return np.polynomial.polynomial.polyval(s, NUM) / np.polynomial.polynomial.polyval(s, DEN)


def _sos_resp(sos, z):
    out = np.ones_like(z)
    for b0, b1, b2, a0, a1, a2 in np.atleast_2d(sos):
        out = out * (b0 + b1 / z + b2 / z**2) / (a0 + a1 / z + a2 / z**2)
    return out


def _ss_resp(A, B, C, D, z):
    return np.array([(C @ np.linalg.solve(zz * np.eye(A.shape[0]) - A, B) + D).item() for zz in z])


def test_plain_bilinear_equals_scipy():
    sos = tustin_sos(NUM, DEN, FS)
    b, a = scipy.signal.bilinear(NUM[::-1], DEN[::-1], fs=FS)
    ref = np.polyval(b, Z) / np.polyval(a, Z)
    assert np.allclose(_sos_resp(sos, Z), ref, rtol=1e-9)
    # the bilinear map: z-response at ω equals the continuous one at the warped 2 f_s tan(ωT/2)
    assert np.allclose(_sos_resp(sos, Z), _cont(2 * FS * np.tan(W / (2 * FS))), rtol=1e-9)


def test_prewarp_is_exact_at_its_frequency():
    f0 = 120.0
    sos = tustin_sos(NUM, DEN, FS, prewarp_hz=f0)
    z0 = np.exp(1j * 2 * np.pi * f0 / FS)
    assert _sos_resp(sos, np.array([z0]))[0] == pytest.approx(_cont(2 * np.pi * f0), rel=1e-9)
    assert abs(_sos_resp(tustin_sos(NUM, DEN, FS), np.array([z0]))[0] - _cont(2 * np.pi * f0)) > 1e-4 * abs(_cont(2 * np.pi * f0))


def test_improper_blocks_are_refused():
    with pytest.raises(ValueError, match="improper"):
        tustin_sos([0.0, 0.0, 1.0], [1.0, 1.0], FS)
    assert tustin_sos([2.0, 0.0], [1.0, 0.0], FS).shape == (1, 6)  # trailing zeros trimmed


def test_sos_ss_runs_like_sosfilt():
    sos = tustin_sos(NUM, DEN, FS)
    A, B, C, D = sos_ss(sos)
    assert A.shape == (2 * len(sos), 2 * len(sos))
    u = np.random.default_rng(0).normal(size=300)
    x = np.zeros((A.shape[0], 1))
    y = []
    for uk in u:
        y.append((C @ x + D * uk).item())
        x = A @ x + B * uk
    assert np.allclose(y, scipy.signal.sosfilt(sos, u), rtol=1e-9, atol=1e-12)
    assert np.allclose(_ss_resp(A, B, C, D, Z), _sos_resp(sos, Z), rtol=1e-9)


def test_batched_transforms_have_the_same_response():
    K = 3
    nums = np.stack([NUM * g for g in (1.0, 2.0, -0.5)])
    dens = np.stack([DEN] * K)
    pw = np.array([0.0, 120.0, 30.0])
    b, a = bilinear_batch(nums[:, None, :], dens, FS, prewarp_hz=pw)
    assert np.allclose(a[:, 0], 1.0)
    sections = tustin_sections_batch(nums, dens, FS, prewarp_hz=pw)
    A, B, C, D = sos_ss_batch(sections)
    Ad, Bd, Cd, Dd = df2t_batch(b, a)
    for i in range(K):
        ref = _sos_resp(tustin_sos(nums[i], dens[i], FS, prewarp_hz=pw[i] or None), Z)
        assert np.allclose(np.polyval(b[i, 0], Z) / np.polyval(a[i], Z), ref, rtol=1e-8)
        assert np.allclose(_sos_resp(sections[i], Z), ref, rtol=1e-8)
        assert np.allclose(_ss_resp(A[i], B[i][:, None], C[i][None, :], D[i], Z), ref, rtol=1e-8)
        assert np.allclose(_ss_resp(Ad[i], Bd[i], Cd[None, :], Dd[i], Z), ref, rtol=1e-8)
    one = sos_ss(sections[0])
    assert np.allclose(A[0], one[0]) and np.allclose(B[0], one[1].ravel()) and np.allclose(C[0], one[2].ravel())


def test_odd_order_gets_a_pole_and_zero_at_the_origin():
    sec = tustin_sections_batch(np.array([[1.0, 0.0]]), np.array([[1.0, 0.1]]), FS)  # 1/(1 + 0.1 s)
    assert sec.shape == (1, 1, 6)
    b0, b1, b2, a0, a1, a2 = sec[0, 0]
    assert b2 == 0.0 and a2 == 0.0 and a0 == 1.0
    assert _sos_resp(sec[0], np.array([1.0]))[0] == pytest.approx(1.0)  # DC gain kept
