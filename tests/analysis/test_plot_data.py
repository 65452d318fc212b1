"""exotune.analysis.plot_data: the responses handed to the plots equal direct evaluations — C7
against the paper's system algebra (exotune.model.plant.seven_systems on the implemented blocks,
a design without DOB, as tests/analysis/test_operator_passivity.py), the DOB loop against Q(jω)
evaluated here from its coefficients, the amplification at the configured delay equal to
compliance_responses' and at the second delay to an analysis of the design at that delay — and the
display conversions on values with known answers."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from exotune.analysis import analyze_design
from exotune.analysis.plot_data import (amplification_at_delays, compliance_responses, db, dob_loop, finite,
                                        freq_grid_hz, phase_deg, second_delay)
from exotune.config import design_from_mapping, load_design
from exotune.model.controller import build_controller

from tests.system_algebra import implemented_systems

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "paper.yaml"


@pytest.fixture(scope="module")
def paper():
    cfg = load_design(EXAMPLE)
    return cfg, analyze_design(cfg).to_dict()


@pytest.fixture(scope="module")
def no_dob():
    raw = copy.deepcopy(load_design(EXAMPLE).raw)
    raw["implementation"]["dob"] = None
    cfg = design_from_mapping(raw)
    return cfg, analyze_design(cfg).to_dict()


def test_c7_equals_the_papers_system_algebra(no_dob):
    cfg, res = no_dob
    r = compliance_responses(cfg, res)
    f = r["f"]
    assert np.all(np.diff(f) > 0)
    np.testing.assert_array_equal(f, freq_grid_hz(res))
    S = implemented_systems(cfg)
    np.testing.assert_allclose(r["C7"], np.ravel(S["S7"].C(2j * np.pi * f)), rtol=1e-8)


def test_dob_loop_equals_q_evaluated_here(paper):
    cfg, res = paper
    d = dob_loop(cfg, res)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    s = 2j * np.pi * d["f"]
    num, den = np.atleast_2d(cs.dob_q.num)[0], np.atleast_2d(cs.dob_q.den)[0]
    Q = np.polynomial.polynomial.polyval(s, num) / np.polynomial.polynomial.polyval(s, den)
    T = float(cfg.implementation.delay_s)
    assert d["T"] == T
    np.testing.assert_allclose(d["Q"], Q, rtol=1e-10)
    L = Q * np.exp(-s * T) / (1 - Q)
    np.testing.assert_allclose(d["L"], L, rtol=1e-9)
    np.testing.assert_allclose(d["CL"], L / (1 + L), rtol=1e-8)
    if d["crossover"] is not None:
        fc, Lc, _ph, target = d["crossover"]
        assert abs(Lc) == pytest.approx(1.0, rel=1e-3)  # the gain crossover
        assert ((target + 180.0) / 360.0).is_integer()


def test_amplification_at_two_delays(paper):
    cfg, res = paper
    f, out = amplification_at_delays(cfg, res)
    T = float(cfg.implementation.delay_s)
    assert [o["T"] for o in out] == [T, second_delay(T)] and [o["configured"] for o in out] == [True, False]
    np.testing.assert_allclose(out[0]["A"], compliance_responses(cfg, res)["A"], rtol=1e-12)
    assert out[0]["bandwidth_hz"] == res["amplification"]["bandwidth_hz"]
    raw = copy.deepcopy(cfg.raw)
    raw["implementation"]["delay_s"] = second_delay(T)
    res2 = analyze_design(design_from_mapping(raw)).to_dict()
    assert out[1]["bandwidth_hz"] == pytest.approx(res2["amplification"]["bandwidth_hz"], rel=1e-6)
    assert out[1]["locked_stable"] == res2["locked_stable"]
    assert out[1]["minimum_phase"] == res2["amplification"]["minimum_phase"]
    # the amplification at DC is the design's α (C6/C5 → α as ω → 0)
    assert abs(out[0]["A"][0]) == pytest.approx(float(cfg.design.amplification), rel=1e-2)


def test_display_conversions():
    assert second_delay(0.001) == pytest.approx(0.003, rel=1e-12)
    assert second_delay(0.005) == pytest.approx(0.010, rel=1e-12)
    np.testing.assert_allclose(db(np.array([10.0, 0.1j])), [20.0, -20.0], rtol=1e-12)
    assert db(np.array([0.0]))[0] == -np.inf
    w = np.linspace(0.01, 20, 400)
    H = np.exp(-1j * w) * 2.0  # phase −ω rad, unwrapped past −180°
    np.testing.assert_allclose(phase_deg(H), np.degrees(-w), rtol=1e-12)
    assert finite(1.0) and not finite(float("inf")) and not finite(None)
