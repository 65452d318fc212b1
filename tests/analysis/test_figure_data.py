"""exotune.analysis.figure_data: the figure data of one analysed design, computed once by the
analysis layer (the plots only draw it; docs/architecture.md)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from exotune.analysis import analyze_design, plot_data
from exotune.analysis.figure_data import (AmplificationRun, AnalysisFigures, C7Response, ComplianceResponses, DobLoop,
                                          HumanLoop, NyquistCritical, NyquistCurve, analysis_figures)
from exotune.analysis.latency_margin import LatencyBoundary
from exotune.analysis.responses import c7_frequency_response
from exotune.config import load_design

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"


@pytest.fixture(scope="module")
def paper():
    cfg = load_design(PAPER)
    r = analyze_design(cfg)
    return cfg, r, analysis_figures(cfg, r)


def test_the_record_is_typed_and_frozen(paper):
    _cfg, _r, figs = paper
    assert isinstance(figs, AnalysisFigures)
    assert isinstance(figs.compliances, ComplianceResponses) and isinstance(figs.c7, C7Response)
    assert isinstance(figs.dob, DobLoop)
    assert figs.human_loops and all(isinstance(lp, HumanLoop) for lp in figs.human_loops)
    assert all(isinstance(c, NyquistCurve) for lp in figs.human_loops for c in lp.curves)
    assert all(isinstance(c, NyquistCritical) for lp in figs.human_loops for c in lp.critical)
    assert all(isinstance(run, AmplificationRun) for run in figs.amplification_at_delays.runs)
    assert figs.latency_boundaries and all(isinstance(b, LatencyBoundary) for b in figs.latency_boundaries)
    with pytest.raises(dataclasses.FrozenInstanceError):
        figs.delay_s = 0.0  # type: ignore[misc]


def test_the_record_holds_the_analysis_layers_numbers(paper):
    """Every array is the one the analysis layer's functions compute, on the same grids."""
    cfg, r, figs = paper
    result = r.to_dict()
    assert figs.result == result
    c = plot_data.compliance_responses(cfg, result)
    for name, key in (("f_hz", "f"), ("C5", "C5"), ("C7", "C7"), ("A", "A")):
        np.testing.assert_array_equal(getattr(figs.compliances, name), c[key])
    assert np.iscomplexobj(figs.compliances.C7) and figs.compliances.f_hz[0] == pytest.approx(plot_data.F_MIN_HZ)
    loops = plot_data.human_loops(cfg, result)
    assert len(loops) == len(figs.human_loops)
    for lp, typed in zip(loops, figs.human_loops):
        assert (typed.kind, typed.parameter, typed.unit) == (lp["h"]["kind"], lp["h"]["parameter"], lp["h"]["unit"])
        for (v, role, state, L, x), curve in zip(lp["curves"], typed.curves, strict=True):
            assert (curve.value, curve.role, curve.state) == (v, role, state)
            np.testing.assert_array_equal(curve.L, L)
            np.testing.assert_array_equal(curve.crossings, x)
        for crit in typed.critical:  # L = −1 at a critical value and frequency
            assert abs(crit.L + 1.0) < 1e-3
    d = plot_data.dob_loop(cfg, result)
    np.testing.assert_array_equal(figs.dob.L, d["L"])
    np.testing.assert_array_equal(figs.dob.phase_L_deg, d["phL"])
    assert figs.dob.delay_s == figs.delay_s == float(np.asarray(cfg.implementation.delay_s))
    f, runs = plot_data.amplification_at_delays(cfg, result)
    np.testing.assert_array_equal(figs.amplification_at_delays.f_hz, f)
    assert [run.configured for run in figs.amplification_at_delays.runs] == [True, False]
    assert figs.amplification_at_delays.runs[1].delay_s == plot_data.second_delay(figs.delay_s)
    f7, C7 = c7_frequency_response(cfg)
    np.testing.assert_array_equal(figs.c7.f_hz, f7)
    np.testing.assert_array_equal(figs.c7.C7, C7)
    assert figs.latency_margin_s is None  # analyze_design computes no margins
    assert figs.name == "paper.yaml" and figs.amplification == float(np.asarray(cfg.design.amplification))


def test_without_a_dob_or_humans_the_record_says_so(paper):
    cfg, _r, _figs = paper
    cfg = dataclasses.replace(cfg, implementation=dataclasses.replace(cfg.implementation, dob=None), humans=())
    figs = analysis_figures(cfg, analyze_design(cfg))
    assert figs.dob is None and figs.human_loops == () and figs.latency_boundaries == ()


def test_the_figures_do_not_analyse_the_design_again(paper, monkeypatch):
    """``analyze --plots`` analyses once: the latency boundaries take the analysis's intervals."""
    import exotune.analysis.batch as batch

    def refuse(*_a, **_k):
        raise AssertionError("analyze_batch called while computing the figure data")

    cfg, r, _figs = paper
    monkeypatch.setattr(batch, "analyze_batch", refuse)
    assert analysis_figures(cfg, r).latency_boundaries
