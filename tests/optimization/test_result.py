"""exotune.optimization.result: the typed view of an optimization report — feasibility, the
objective value and the written path — and its text, which carries the units of the objective
and of every bound."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

from exotune.config import load_design
from exotune.optimization.result import OptimizeResult
from exotune.optimization.search import optimize
from exotune.optimization.spec import load_optimize_spec

BASE = copy.deepcopy(load_design(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml").raw)
BASE["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0},
                  {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]


def _report(objective="amplification", **constraints):
    spec = load_optimize_spec({"base": copy.deepcopy(BASE), "objective": objective, "budget": 50,
                               "free": {"design.amplification": [1.5, 60.0], "design.felt_inertia": [0.05, 1.0]},
                               "constraints": {"latency_margin_s": 0.0, **constraints}})
    return optimize(spec)


@pytest.fixture(scope="module")
def report():
    return _report(max_phase_excess_deg=20.0, amplification_bandwidth_hz=2.0)


def test_from_report_reads_feasibility_value_and_path(report, tmp_path):
    r = OptimizeResult.from_report(report, tmp_path / "x.yaml")
    assert r.feasible and r.path == str(tmp_path / "x.yaml")
    assert r.objective_value == pytest.approx(report["objective"]["value"])
    assert r.to_dict() == report
    assert OptimizeResult.from_report(report).path is None
    bad = dict(report, feasible=False)
    assert OptimizeResult.from_report(bad, tmp_path / "x.yaml").path is None


def test_the_text_carries_the_units(report):
    text = OptimizeResult.from_report(report).to_text()
    assert "amplification" in text
    assert "deg" in text and "Hz" in text  # the bounds of the constraints, with their units
    assert "kg·m²" in text  # the free felt inertia's unit
    f = _report(objective="felt_inertia", max_phase_excess_deg=20.0)
    assert "kg·m²" in OptimizeResult.from_report(f).to_text()


def test_an_infeasible_report_says_so(tmp_path):
    rep = _report(amplification_bandwidth_hz=1e6)
    r = OptimizeResult.from_report(rep, tmp_path / "none.yaml")
    assert not r.feasible and r.path is None
    text = r.to_text()
    assert "amplification_bandwidth_hz" in text and "Hz" in text
