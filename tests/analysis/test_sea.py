"""exotune.analysis.sea: the numbers of ``exotune sea`` against closed forms of the second-order
SEA derived here from its physics (paper §II-B): motor J_m θ̈_m + B_m θ̇_m = τ_m + K_s θ_s,
θ_s = θ_j − θ_m, output torque τ_j = K_s θ_s, τ_m = −(K1 + B1 s) θ_m + (K2 + B2 s) θ_s gives

    C4 = θ_j/τ_j = (J_m s² + (B_m + B1 + B2) s + K_s + K1 + K2) / (K_s (J_m s² + (B_m + B1) s + K1)),

C5 = (C4⁻¹ + J_j s²)⁻¹; the resonance and phase extremes against dense frequency sweeps."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.analysis.sea import SEA_UNITS, sea_report
from exotune.config.design import sea_from_mapping
from exotune.config.yamlio import read_yaml

EXAMPLE = read_yaml(Path(__file__).resolve().parents[2] / "examples" / "sea.yaml")
P = EXAMPLE["plant"]
JM, BM, KS, JJ = P["motor_inertia"], P["motor_damping"], P["sea_stiffness"], P["joint_inertia"]
F = np.geomspace(1e-3, 1e4, 400_001)


def _report(**gains):
    m = copy.deepcopy(EXAMPLE)
    m["gains"].update(gains)
    return sea_report(sea_from_mapping(m)).to_dict(), m["gains"]


def _c4_c5(g, s):
    n = JM * s**2 + (BM + g["B1"] + g["B2"]) * s + KS + g["K1"] + g["K2"]
    d = KS * (JM * s**2 + (BM + g["B1"]) * s + g["K1"])
    c4 = n / d
    return c4, 1.0 / (1.0 / c4 + JJ * s**2)


def _c5_poles(g):
    # C5 = n / (d + J_j s² n): poles are the roots of d + J_j s² n (descending coefficients)
    n = np.array([JM, BM + g["B1"] + g["B2"], KS + g["K1"] + g["K2"]])
    d = KS * np.array([JM, BM + g["B1"], g["K1"]])
    return np.roots(np.polyadd(np.polymul([JJ, 0.0, 0.0], n), d))


CASES = [{}, {"B2": 50.0, "K2": -20000.0}, {"K1": 20000.0, "B1": 400.0, "K2": 0.0, "B2": 0.0}]


@pytest.mark.parametrize("gains", CASES)
def test_stiffness_poles_and_shape_against_the_closed_form(gains):
    r, g = _report(**gains)
    assert r["low_frequency_stiffness"] == pytest.approx(KS * g["K1"] / (KS + g["K1"] + g["K2"]), rel=1e-9)
    sh = r["shape"]
    assert sh["K1_tilde"] == pytest.approx(g["K1"] / JM, rel=1e-12)
    assert sh["B2_tilde"] == pytest.approx((BM + g["B1"] + g["B2"]) / JM, rel=1e-12)
    ref = sorted(_c5_poles(g), key=lambda z: (z.real, z.imag))
    got = sorted((p["re"] + 1j * p["im"] for p in r["c5_poles"]), key=lambda z: (z.real, z.imag))
    assert len(got) == 4
    np.testing.assert_allclose(got, ref, rtol=1e-7)
    assert r["c5_stable"] == bool(np.all(np.real(ref) < 0))
    assert r["units"] == dict(SEA_UNITS)


@pytest.mark.parametrize("gains", CASES)
def test_resonance_and_phase_extremes_against_a_dense_sweep(gains):
    r, g = _report(**gains)
    c4, c5 = _c4_c5(g, 2j * np.pi * F)
    mag = np.abs(c5)
    k = int(np.argmax(mag))
    assert 0 < k < F.size - 1  # an interior peak
    assert r["resonance_hz"] == pytest.approx(F[k], rel=1e-3)
    assert r["resonance_peak_compliance"] == pytest.approx(mag[k], rel=1e-6)
    ph = np.degrees(np.unwrap(np.angle(c4)))
    assert r["max_phase_deg"] == pytest.approx(ph.max(), abs=1e-3)
    assert r["min_phase_deg"] == pytest.approx(ph.min(), abs=1e-3)
    assert r["max_phase_deg"] >= ph.max() - 1e-9


@pytest.mark.parametrize("gains", CASES)
def test_the_passivity_verdict_agrees_with_the_phase_of_c4(gains):
    r, g = _report(**gains)
    c4, _ = _c4_c5(g, 2j * np.pi * F)
    ph = np.degrees(np.angle(c4))
    sweep_passive = bool(np.all((ph <= 1e-9) & (ph >= -180.0 - 1e-9)))
    assert r["passivity"]["passive"] == sweep_passive
    assert r["passivity"]["passive"] == (not r["passivity"]["failed_conditions"])
    assert ("C4 phase exceeds 0°" in " ".join(r["notes"])) == (r["max_phase_deg"] > 0)


def test_the_example_is_stable_stiffer_than_its_spring_and_not_passive():
    r, g = _report()
    assert r["c5_stable"] and not r["c5_rigid_body_mode"]
    assert r["low_frequency_stiffness"] > KS
    assert "B2 >= 0" in r["passivity"]["failed_conditions"]


def test_without_motor_position_feedback_the_joint_has_a_rigid_body_mode():
    r, _ = _report(K1=0.0)
    assert r["low_frequency_stiffness"] == 0.0
    assert r["c5_rigid_body_mode"]
    assert any("zero static stiffness" in n for n in r["notes"])


@settings(max_examples=15, deadline=None)
@given(k1=st.floats(1e3, 1e5), b1=st.floats(0.0, 2e3), k2=st.floats(-2e4, 2e4), b2=st.floats(0.0, 500.0))
def test_gains_in_torque_units_give_the_same_report(k1, b1, k2, b2):
    a, _ = _report(K1=k1, B1=b1, K2=k2, B2=b2)
    b, _ = _report(units="torque", K1=k1, B1=b1, K2=k2 / KS, B2=b2 / KS)
    assert b["low_frequency_stiffness"] == pytest.approx(a["low_frequency_stiffness"], rel=1e-9)
    for k in a["shape"]:
        assert b["shape"][k] == pytest.approx(a["shape"][k], rel=1e-9, abs=1e-9)
    assert b["c5_stable"] == a["c5_stable"] and b["passivity"]["passive"] == a["passivity"]["passive"]


def test_a_lossless_sea_is_not_called_stable():
    """B_m + B1 = 0 and B2 = 0: C5's poles lie on the imaginary axis (no damping anywhere); the
    eigenvalue solver returns them with rounding-sized real parts, which read "stable" before. The
    exact Routh test calls the SEA not stable; any damping makes it stable."""
    r, g = _report(K1=20000.0, B1=-BM, K2=0.0, B2=0.0)
    assert np.max(np.abs(_c5_poles(g).real)) < 1e-6  # on the axis up to rounding
    assert not r["c5_stable"]
    r2, _ = _report(K1=20000.0, B1=-BM + 1.0, K2=0.0, B2=0.0)
    assert r2["c5_stable"]


@pytest.mark.parametrize("k1, stable", [(1e-300, True), (-1e-300, False), (5e-324, True), (0.0, True)])
def test_a_tiny_position_gain_is_decided_by_its_sign(k1, stable):
    """K1 = ±1e-300 adds a pole at ∓5.6e-302 rad/s, which the eigenvalue solver returns as 0 (it
    read UNSTABLE for +1e-300 while K1 = 0 read stable); the exact test decides it by the sign of
    the constant term. K1 = 0 is the rigid-body mode, excused."""
    r, _ = _report(K1=k1, B1=0.0, K2=0.0, B2=0.0)
    assert r["c5_stable"] is stable
    assert r["c5_rigid_body_mode"] is (k1 == 0.0)
