"""exotune.simulation.verdict: the envelope growth rate of a run (against signals of known
growth), the verdict, the dominant frequency and the linearized loop's spectral radius."""

import math

import numpy as np
import pytest

from exotune.simulation.verdict import (FLOOR, MARGINAL_TOL, classify, dominant_frequency, envelope_growth,
                                        loop_spectral_radius)

from paper_design import paper_controller

T = np.arange(0.0, 10.0, 1e-3)


@pytest.mark.parametrize("sigma", [-0.8, -0.3, 0.3, 0.8])
def test_growth_of_an_exponential_oscillation_is_its_exponent(sigma):
    s = 2.0 + np.exp(sigma * T) * np.sin(2 * np.pi * 3.0 * T)  # the constant offset drops out
    g, died = envelope_growth(T, s)
    assert died is None
    assert g == pytest.approx(sigma, abs=0.05)


def test_a_sustained_oscillation_is_marginal():
    g, died = envelope_growth(T, np.sin(2 * np.pi * 5.0 * T))
    assert abs(g) < MARGINAL_TOL and died is None
    assert classify(g, died, False) == "marginal"


def test_an_oscillation_that_dies_out_says_when():
    s = np.where(T < 2.0, np.exp(-3.0 * T) * np.sin(2 * np.pi * 4 * T), 0.0)
    g, died = envelope_growth(T, s)
    assert died is not None and died <= 2.0
    assert classify(g, died, False) == "decaying"
    flat_g, flat_died = envelope_growth(T, np.full(T.size, 3.0))  # no oscillation at all
    assert flat_g == -math.inf and flat_died == T[0]


def test_periodic_push_compares_over_one_period():
    forced = np.sin(2 * np.pi * 1.0 * T) + np.exp(-1.0 * T) * np.sin(2 * np.pi * 7.0 * T)
    g, _ = envelope_growth(T, forced, lag=1000)  # period 1 s = 1000 samples: the transient decays
    assert g == pytest.approx(-1.0, abs=0.1)


def test_short_and_non_finite_runs():
    assert envelope_growth(T[:5], np.ones(5)) == (None, None)
    s = np.sin(T)
    s[-1] = np.inf
    assert envelope_growth(T, s)[0] == math.inf
    assert FLOOR < 1e-6


@pytest.mark.parametrize("growth, died, diverged, verdict", [
    (0.0, None, True, "growing"), (-5.0, None, True, "growing"),
    (1.0, 3.2, False, "decaying"), (1.0, None, False, "growing"), (-1.0, None, False, "decaying"),
    (MARGINAL_TOL, None, False, "marginal"), (-MARGINAL_TOL, False, False, "marginal"), (None, None, False, "marginal"),
])
def test_classify(growth, died, diverged, verdict):
    assert classify(growth, died, diverged) == verdict


@pytest.mark.parametrize("f0", [3.3, 12.0, 47.5])
def test_dominant_frequency_within_a_fraction_of_a_bin(f0):
    s = 0.5 + np.sin(2 * np.pi * f0 * T) + 0.1 * np.sin(2 * np.pi * 3 * f0 * T)
    assert dominant_frequency(T, s) == pytest.approx(f0, abs=0.1 * (1 / 10.0))  # a tenth of the 0.1 Hz bin
    assert math.isnan(dominant_frequency(T[:10], s[:10]))


@pytest.fixture(scope="module")
def doc():
    return paper_controller(1000.0, delay_s=0.001)


def test_spectral_radius_follows_the_certified_light_mass_boundary(doc):
    """certify's stable interval of the mass family starts at the light-mass boundary: ρ < 1 above it,
    ρ > 1 below it."""
    lo = doc["predicted"]["sampled"]["humans"][0]["stable_intervals"][0][0]
    assert loop_spectral_radius(doc, {"inertia": 1.02 * lo}, False) < 1.0
    assert loop_spectral_radius(doc, {"inertia": 0.98 * lo}, False) > 1.0
    assert loop_spectral_radius(doc, {"inertia": 0.5, "damping": 2.0}, True) < 1.0
