"""The numbers of ``exotune design`` (exotune.analysis.design_summary) and the one-transfer-function
methods of exotune.numerics.poly.Rational they use, against closed forms, python-control and
dense frequency sweeps."""

from __future__ import annotations

import math
from pathlib import Path

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.analysis.design_summary import (approximation_limit_hz, bode_curves, design_report, phase_extremum,
                                             resonance, root_entries)
from exotune.config import load_design
from exotune.model.shaping import double_compliance_shaping, nominal_transfer_functions
from exotune.numerics.poly import Rational, poly_roots, root_grid

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "paper.yaml"


@settings(max_examples=30, deadline=None)
@given(wn=st.floats(0.5, 500.0), zeta=st.floats(0.02, 0.6))
def test_resonance_of_a_second_order_lowpass_is_the_closed_form(wn, zeta):
    """H = 1/(s² + 2ζω_n s + ω_n²): peak at ω_n√(1 − 2ζ²), of height 1/(2ζ√(1 − ζ²) ω_n²)."""
    tf = Rational(np.array([1.0]), np.array([wn * wn, 2 * zeta * wn, 1.0]))
    f, peak = resonance(tf)
    assert f == pytest.approx(wn * math.sqrt(1 - 2 * zeta**2) / (2 * math.pi), rel=1e-6)
    assert peak == pytest.approx(1.0 / (2 * zeta * math.sqrt(1 - zeta**2) * wn**2), rel=1e-9)


def test_no_resonance_above_the_critical_damping():
    assert resonance(Rational(np.array([1.0]), np.array([1.0, 2.0, 1.0]))) == (None, None)


@settings(max_examples=30, deadline=None)
@given(z=st.floats(0.1, 10.0), ratio=st.floats(2.0, 100.0))
def test_phase_extremum_of_a_lead_is_the_closed_form(z, ratio):
    """(1 + s/z)/(1 + s/p), p = ratio·z: maximum phase asin((p − z)/(p + z)) at √(z p)."""
    p = ratio * z
    tf = Rational(np.array([1.0, 1.0 / z]), np.array([1.0, 1.0 / p]))
    ph, f = phase_extremum(tf, +1)
    assert ph == pytest.approx(math.degrees(math.asin((p - z) / (p + z))), rel=1e-9)
    assert f == pytest.approx(math.sqrt(z * p) / (2 * math.pi), rel=1e-5)
    lo, f0 = phase_extremum(tf, -1)  # the minimum is the limit 0° at ω → 0 (or ∞)
    assert lo == pytest.approx(0.0, abs=1e-12) and f0 in (0.0, math.inf)


def test_rational_minimal_poles_zeros_and_response_against_python_control():
    num, den = np.array([0.0, 0.0, 3.0, 1.0]), np.array([0.0, 0.0, 2.0, 5.0, 1.0, 0.0])
    m = Rational(num, den).minimal()
    assert m.num.tolist() == [3.0, 1.0] and m.den.tolist() == [2.0, 5.0, 1.0]
    ref = control.TransferFunction(m.num[::-1], m.den[::-1])
    np.testing.assert_allclose(np.sort_complex(m.poles()), np.sort_complex(ref.poles()), rtol=1e-12)
    np.testing.assert_allclose(np.sort_complex(m.zeros()), np.sort_complex(ref.zeros()), rtol=1e-12)
    w = np.geomspace(0.01, 100.0, 50)
    np.testing.assert_allclose(m.at_jw(w), np.ravel(ref(1j * w)), rtol=1e-12)
    # roots sorted by magnitude; the grid spans every root ± the span
    r = poly_roots(np.array([6.0, -5.0, 1.0]))
    assert np.allclose(r, [2.0, 3.0])
    g = root_grid(np.array([6.0, -5.0, 1.0]), span=1.0, per_decade=10)
    assert g[0] == pytest.approx(0.2) and g[-1] == pytest.approx(30.0)


def test_root_entries_units():
    e = root_entries([complex(-3.0, 4.0), 0j])
    assert e[0]["natural_frequency_hz"] == pytest.approx(5.0 / (2 * math.pi))
    assert e[0]["damping_ratio"] == pytest.approx(0.6)
    assert math.isnan(e[1]["damping_ratio"])


def test_design_report_transfer_functions_against_python_control():
    cfg = load_design(EXAMPLE)
    rep = design_report(cfg).to_dict()
    ds = double_compliance_shaping(cfg.plant, cfg.design)
    tfs = nominal_transfer_functions(cfg.plant, cfg.design, ds)
    for name, tf in tfs.items():
        entry = rep["transfer_functions"][name]
        # the report cancels the common exact roots at s = 0; python-control's poles of the full
        # num/den, without their zero poles, are the report's non-zero poles
        ours = np.array([complex(p["re"], p["im"]) for p in entry["poles"]])
        theirs = np.asarray(tf.to_control().poles())
        np.testing.assert_allclose(np.sort_complex(ours[np.abs(ours) > 0]),
                                   np.sort_complex(theirs[np.abs(theirs) > 1e-9]), rtol=1e-7)
    # the approximation limit: |C5/Ĉ5 − 1| reaches 0.1 there, and stays below it under it
    f_lim = approximation_limit_hz(tfs)
    assert f_lim == rep["approximation"]["valid_below_hz"]
    ratio = lambda f: tfs["C5"].minimal().at_jw(2 * np.pi * np.atleast_1d(f)) / tfs["C5_hat"].minimal().at_jw(2 * np.pi * np.atleast_1d(f))  # noqa: E731
    assert abs(ratio(f_lim)[0] - 1.0) == pytest.approx(0.1, rel=1e-6)
    below = np.geomspace(f_lim * 1e-3, f_lim * 0.999, 200)
    assert np.all(np.abs(ratio(below) - 1.0) < 0.1)


def test_bode_curves_are_the_responses_on_one_grid():
    tf1 = Rational(np.array([1.0]), np.array([1.0, 1.0]))
    tf2 = Rational(np.array([1.0]), np.array([100.0, 1.0]))
    (l1, f1, m1, p1), (l2, f2, m2, p2) = bode_curves([("a", tf1), ("b", tf2)])
    assert (l1, l2) == ("a", "b") and np.array_equal(f1, f2)
    np.testing.assert_allclose(m1, 20 * np.log10(np.abs(1.0 / (1.0 + 2j * np.pi * f1))), rtol=1e-12)
    np.testing.assert_allclose(p2, -np.degrees(np.arctan(2 * np.pi * f2 / 100.0)), atol=1e-9)
    assert f1[0] == pytest.approx(10**-1.5 / (2 * np.pi)) and f1[-1] == pytest.approx(10**3.5 / (2 * np.pi))
