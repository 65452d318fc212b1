"""exotune.simulation.verdict: the envelope growth rate of a run (against signals of known
growth), the verdict, the dominant frequency and the linearized loop's spectral radius."""

import math

import numpy as np
import pytest

from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.simulation.verdict import (FLOOR, MARGINAL_TOL, MIN_PERIODS, VERDICTS, LoopSpectrum, classify,
                                        dominant_frequency, envelope_growth, judge, loop_spectral_radius,
                                        loop_spectrum, spectrum_of)

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


# ---------------------------------------------------------------------------------------------
# h8 item 3: a run shorter than two periods of the loop's dominant oscillation read "decaying" for
# a growing loop (16 samples at 1 kHz against a 44 Hz oscillation with ρ = 1.00311)
# ---------------------------------------------------------------------------------------------
def test_the_dominant_oscillation_is_the_slowest_live_one():
    """Real modes do not oscillate; a pair that falls below FLOOR within half a period (a real
    double root split by rounding) shows nothing an envelope could follow; among the others the
    largest modulus decides, and a negative real eigenvalue oscillates at f_s/2."""
    fs = 1000.0
    pair = lambda r, th: [r * np.exp(1j * th), r * np.exp(-1j * th)]  # noqa: E731
    sp = spectrum_of([0.9999, *pair(0.9999, 1e-6), *pair(0.99, 2 * np.pi * 5 / fs), *pair(0.98, 2 * np.pi * 40 / fs)],
                     fs)
    assert sp.spectral_radius == pytest.approx(0.9999)
    assert sp.oscillation_hz == pytest.approx(5.0) and sp.oscillation_modulus == pytest.approx(0.99)
    assert sp.oscillation_period_s == pytest.approx(0.2) and sp.needed_run_s == pytest.approx(MIN_PERIODS * 0.2)
    assert sp.growth_rate_per_s == pytest.approx(fs * math.log(0.9999))
    assert spectrum_of([0.5, 0.9999], fs).needed_run_s is None  # no oscillation: no period to wait for
    assert spectrum_of([-0.5, 0.3], fs).oscillation_hz == pytest.approx(fs / 2)
    assert spectrum_of([], fs) == LoopSpectrum(0.0, fs)
    # equal moduli: the longer period (the slower oscillation) is the one to wait for
    assert spectrum_of([*pair(0.99, 0.2), *pair(0.99, 0.02)], fs).oscillation_hz == pytest.approx(0.02 * fs / (2 * np.pi))


def test_the_loop_spectrum_of_the_light_mass_repro(doc):
    """The repro's loop: ρ = 1.00311 with a 44.3 Hz dominant oscillation (two periods: 45 ms > 16 ms)."""
    sp = loop_spectrum(doc, {"inertia": 5e-3}, False)
    assert sp.spectral_radius == pytest.approx(1.00311, abs=1e-5) == loop_spectral_radius(doc, {"inertia": 5e-3}, False)
    assert sp.oscillation_hz == pytest.approx(44.29, abs=0.01) and sp.verdict == "growing"
    assert 0.016 < sp.needed_run_s == pytest.approx(0.04515, abs=1e-4)


GROWING = LoopSpectrum(1.00311, 1000.0, 44.29, 1.00311)
STABLE = LoopSpectrum(0.99, 1000.0, 44.29, 0.99)


@pytest.mark.parametrize("envelope, run_s, spectrum, died, diverged, want", [
    ("decaying", 0.016, GROWING, False, False, ("growing", "spectral_radius")),  # the repro: was "decaying"
    ("decaying", 0.016, STABLE, False, False, ("inconclusive", "none")),  # too short to judge
    ("growing", 0.016, STABLE, False, False, ("inconclusive", "none")),
    ("marginal", 0.016, STABLE, False, False, ("inconclusive", "none")),
    ("decaying", 0.016, STABLE, True, False, ("decaying", "envelope")),  # died out to rounding: the run shows it
    ("decaying", 0.016, GROWING, True, False, ("growing", "spectral_radius")),
    ("decaying", 0.016, STABLE, False, True, ("growing", "stopped")),
    ("decaying", 10.0, STABLE, False, False, ("decaying", "envelope")),
    ("decaying", 10.0, GROWING, False, False, ("growing", "spectral_radius")),  # the eigenvalue verdict wins
    ("marginal", 10.0, GROWING, False, False, ("growing", "spectral_radius")),
    ("growing", 10.0, GROWING, False, False, ("growing", "envelope")),
    ("growing", 10.0, STABLE, False, False, ("growing", "envelope")),  # a nonlinearity may destabilize: kept
    ("decaying", 10.0, LoopSpectrum(1.0 + 1e-9, 1000.0, 44.29, 1.0), False, False, ("marginal", "spectral_radius")),
    ("decaying", 0.016, LoopSpectrum(0.99, 1000.0), False, False, ("decaying", "envelope")),  # no oscillation
    ("decaying", 0.016, None, False, False, ("decaying", "envelope")),  # the loop not known
])
def test_judge_weighs_the_envelope_against_the_loop(envelope, run_s, spectrum, died, diverged, want):
    assert judge(envelope, run_s, spectrum, died, diverged) == want


@settings(max_examples=200, deadline=None)
@given(envelope=st.sampled_from(VERDICTS[:3]), run_s=st.floats(1e-3, 100.0), rho=st.floats(1.0, 2.0, exclude_min=True),
       hz=st.one_of(st.none(), st.floats(0.01, 500.0)), died=st.booleans())
def test_a_loop_with_rho_above_one_is_never_decaying(envelope, run_s, rho, hz, died):
    sp = LoopSpectrum(rho, 1000.0, hz, None if hz is None else rho)
    verdict, basis = judge(envelope, run_s, sp, died)
    assert verdict in ("growing", "marginal")
    assert verdict == envelope or basis == "spectral_radius"
