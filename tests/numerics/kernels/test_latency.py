"""exotune.numerics.kernels.latency: the compiled latency margin (the smallest extra delay that
puts a root on the imaginary axis) against the closed form of first-order delay loops.

Δ(s) = α s + a + k e^{−sT} (k > |a|) has its gain crossover at ω_c = √(k² − a²)/α, where
e^{−jω_c τ} = −(a + jαω_c)/k: the extra delay is (π − atan2(αω_c, a))/ω_c − T (mod 2π/ω_c).
A family Δ_p = (1 + p) s + a + (k + p c) e^{−sT}, p ∈ [lo, hi], is the same loop member by member:
its margin is the minimum of that closed form over p (a dense set of members)."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.analysis.latency import (BISECTION_ITERATIONS, GOLDEN_ITERATIONS, GRAZE_REL, GRID_DECADES,
                                      GRID_PER_DECADE, MAX_CROSSINGS, PEAK_ITERATIONS, SEED_POINTS, DIP_ITERATIONS, BRANCH_REL, EDGE_ITERATIONS,
                                      SHRINK_ITERATIONS)
from exotune.numerics.kernels import AVAILABLE

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed")


def _closed_form(alpha, a, k, T):
    wc = np.sqrt(k**2 - a**2) / alpha
    return np.mod(np.pi - np.arctan2(alpha * wc, a) - wc * T, 2 * np.pi) / wc


def _run(a, k, c, T, lo, hi, curve):
    from exotune.numerics.kernels.latency import design_margins

    K = a.size
    z = np.zeros(K)
    one = np.ones(K)
    # even/odd parts in x = ω² of P0, P1 of pair 0 (s + a, k) and pair 1 (s, c): P(jω) = E + jω O
    ev = np.stack([a, k, z, c])[:, :, None].copy()
    od = np.stack([one, z, one, z])[:, :, None].copy()
    members = np.array([[lo, hi]])
    return design_margins(
        ev, od, np.array([0]), np.array([1]), np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]]), np.array([1.0]),
        np.array([0.0]), members, np.array([2 if hi > lo else 1]), np.array([lo]), np.array([hi]), np.array([curve]),
        np.ascontiguousarray(T, dtype=float), np.full(K, 1e4), GRID_DECADES, int(GRID_DECADES * GRID_PER_DECADE) + 1,
        BISECTION_ITERATIONS, SHRINK_ITERATIONS, GOLDEN_ITERATIONS, GRAZE_REL, SEED_POINTS, MAX_CROSSINGS,
        PEAK_ITERATIONS, DIP_ITERATIONS, BRANCH_REL, EDGE_ITERATIONS)


def test_single_member_margin_equals_the_closed_form():
    rng = np.random.default_rng(0)
    K = 25
    k = rng.uniform(2.0, 200.0, K)
    a = k * rng.uniform(-0.9, 0.9, K)
    T = rng.uniform(0.0, 0.3, K) / k
    got = _run(a, k, np.zeros(K), T, 0.0, 0.0, False)
    np.testing.assert_allclose(got, _closed_form(1.0, a, k, T), rtol=1e-9)


def test_no_crossing_means_an_infinite_margin():
    """|a| > |k|: |P0(jω)| > |P1(jω)| at every ω, the delay never destabilizes."""
    got = _run(np.array([5.0, -5.0]), np.array([4.0, 4.0]), np.zeros(2), np.array([0.0, 0.01]), 0.0, 0.0, False)
    assert np.isinf(got).all()


@pytest.mark.parametrize("c", [-3.0, 0.0, 2.0])
def test_family_margin_is_the_minimum_over_its_members(c):
    rng = np.random.default_rng(1)
    K = 8
    k = rng.uniform(20.0, 60.0, K)
    a = k * rng.uniform(-0.5, 0.5, K)
    T = rng.uniform(0.0, 0.2, K) / k
    lo, hi = 0.0, 3.0
    got = _run(a, k, np.full(K, c), T, lo, hi, True)
    p = np.linspace(lo, hi, 30001)[:, None]
    ref = _closed_form(1.0 + p, a[None, :], k[None, :] + p * c, T[None, :]).min(axis=0)
    np.testing.assert_allclose(got, ref, rtol=1e-6)
    # a family is never more robust than its end members
    ends = np.minimum(_closed_form(1.0 + lo, a, k + lo * c, T), _closed_form(1.0 + hi, a, k + hi * c, T))
    assert np.all(got <= ends * (1 + 1e-9))
