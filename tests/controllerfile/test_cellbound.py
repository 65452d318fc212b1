"""exotune.controllerfile.cellbound: the proof that a whole cell of a family is stable. The disc
test never proves a family with an unstable member (its members' spectral radii computed directly),
proves a clearly stable one with a margin that bounds every member's radius, accounts for the
bounded remainder (a large enough β defeats the proof), and deflates a common eigenvector at
z = 1; the Taylor coefficients of the exponential are scipy's exponential and its Fréchet
derivative."""

from __future__ import annotations

import numpy as np
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.controllerfile.cellbound import ORDER, disc_test, taylor_expm

DELTAS = np.linspace(-0.5, 0.5, 41)


def _radius(coeffs, d):
    return max(abs(np.linalg.eigvals(sum(d ** k * c for k, c in enumerate(coeffs)))))


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 5), st.floats(0.2, 1.3), st.floats(0.0, 0.4), st.integers(0, 2**32 - 1))
def test_a_proof_bounds_every_member(n, r0, spread, seed):
    rng = np.random.default_rng(seed)
    M0 = rng.normal(size=(n, n))
    M0 *= r0 / max(abs(np.linalg.eigvals(M0)))
    coeffs = [M0, spread * rng.normal(size=(n, n)) / n]
    ok, margin = disc_test(coeffs)
    radii = [_radius(coeffs, d) for d in DELTAS]
    if ok:
        assert margin > 0 and max(radii) <= 1.0 - margin + 1e-12
    else:
        assert margin <= 0
    if max(radii) >= 1.0:
        assert not ok


def test_a_contraction_is_proven():
    M0 = np.diag([0.5, -0.3, 0.2])
    ok, margin = disc_test([M0, 0.05 * np.ones((3, 3))])
    assert ok and 0 < margin <= 1 - max(_radius([M0, 0.05 * np.ones((3, 3))], d) for d in DELTAS) + 1e-12


def test_the_remainder_counts():
    M0 = np.diag([0.5, 0.4])
    assert disc_test([M0], np.eye(2), np.eye(2), beta=0.1)[0]
    assert not disc_test([M0], np.eye(2), np.eye(2), beta=0.6)[0]  # Δ = 0.6 I makes 0.5 + 0.6 > 1


def test_a_common_eigenvector_at_one_is_deflated():
    v = np.array([1.0, 0.0, 0.0])
    M0 = np.array([[1.0, 0.2, 0.1], [0.0, 0.5, 0.1], [0.0, 0.0, -0.3]])
    M1 = np.array([[0.0, 0.1, 0.0], [0.0, 0.05, 0.0], [0.0, 0.02, 0.05]])  # M1 v = 0
    assert not disc_test([M0, M1])[0]  # the eigenvalue 1 is not inside the open disk
    ok, margin = disc_test([M0, M1], rigid=v)
    assert ok and margin > 0


def test_taylor_coefficients_are_the_exponential_and_its_derivative():
    rng = np.random.default_rng(5)
    N, dN, t = rng.normal(size=(4, 4)), rng.normal(size=(4, 4)), 0.2
    c = taylor_expm(N, dN, t, ORDER)
    assert len(c) == ORDER + 1
    np.testing.assert_allclose(c[0], scipy.linalg.expm(N * t), rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(c[1], scipy.linalg.expm_frechet(N * t, dN * t)[1], rtol=1e-10, atol=1e-12)
    s = 1e-3  # the Taylor polynomial reproduces exp((N + s dN) t) to O(s^(ORDER+1))
    approx = sum(s ** k * ck for k, ck in enumerate(c))
    np.testing.assert_allclose(approx, scipy.linalg.expm((N + s * dN) * t), rtol=1e-10, atol=1e-12)


def test_taylor_at_zero_time_is_the_identity():
    c = taylor_expm(np.ones((2, 2)), np.ones((2, 2)), 0.0, 2)
    np.testing.assert_array_equal(c[0], np.eye(2))
    assert all(not ck.any() for ck in c[1:])


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 130), lam=st.floats(0.0, 0.99), eps=st.sampled_from([0.0, 1e-300, 1e-200, 1e-14, 1e-6]),
       blocks=st.integers(1, 3))
def test_defective_loops_never_raise_and_a_proof_is_true(n, lam, eps, blocks):
    """Hostile round 4: a controller file with 120 identity sections per filter (nilpotent blocks
    at z = 0 in the loop matrix) made certify fail with "SVD did not converge" (exit 2, no report).
    On Jordan chains (defective, or nearly so through a tiny coupling ε) disc_test returns a
    verdict, never an exception, and a cell it proves is Schur stable at both ends."""
    J = lam * np.eye(n) + np.diag(np.ones(n - 1), 1)
    J[-1, 0] = eps
    M0 = scipy.linalg.block_diag(*([J] * blocks))
    M1 = 1e-3 * np.eye(M0.shape[0])
    with np.errstate(all="ignore"):
        ok, margin = disc_test([M0, M1])
    assert isinstance(ok, bool) and (margin > 0) == ok
    if ok:
        for d in (-0.5, 0.5):
            assert max(abs(np.linalg.eigvals(M0 + d * M1))) < 1.0
