"""exotune.optimization.diagnose on a one-parameter problem (the amplification α of
examples/paper.yaml): parameters at their bounds, the broken constraints of rows of a batch
evaluation against the single-design analysis of the same designs, and the exact latency margin of
a design against exotune.analysis.latency_margin of the design built here."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from exotune.analysis import analyze_design
from exotune.analysis.latency_margin import latency_margin
from exotune.config import design_from_mapping, load_design
from exotune.optimization import load_optimize_spec
from exotune.optimization.evaluate import evaluate
from exotune.optimization.diagnose import at_bounds, exact_latency_margin, violations

ROOT = Path(__file__).resolve().parents[2]
LO, HI = 1.5, 60.0
PHASE = 12.0  # the phase excess falls from 13.6° (α = 1.5) to 10.5° (α = 60)


def _base():
    raw = copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)
    raw["implementation"]["delay_s"] = 0.002
    raw["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0},
                     {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]
    return raw


@pytest.fixture(scope="module")
def spec():
    return load_optimize_spec({"base": _base(), "objective": "amplification",
                               "free": {"design.amplification": [LO, HI]},
                               "constraints": {"max_phase_excess_deg": PHASE}, "budget": 50})


def _cfg(alpha):
    raw = _base()
    raw["design"]["amplification"] = float(alpha)
    return design_from_mapping(raw)


def test_at_bounds(spec):
    assert at_bounds(spec, np.array([0.0]), np.array([LO])) == [
        {"parameter": "design.amplification", "bound": "lower", "value": LO}]
    assert at_bounds(spec, np.array([1.0]), np.array([HI])) == [
        {"parameter": "design.amplification", "bound": "upper", "value": HI}]
    assert at_bounds(spec, np.array([0.5]), np.array([30.0])) == []


def test_violations_match_the_single_design_analysis(spec):
    alphas = np.array([2.0, 8.0, 30.0, 60.0])
    ev = evaluate(spec, alphas[:, None])
    seen = set()
    for i, a in enumerate(alphas):
        rep = analyze_design(_cfg(a)).to_dict()
        v = {x["constraint"]: x for x in violations(spec, ev, i, None)}
        excess = rep["passivity"]["max_phase_excess_deg"]
        assert ("max_phase_excess_deg" in v) == (excess > PHASE), (a, excess)
        seen.add(excess > PHASE)
        if "max_phase_excess_deg" in v:
            assert v["max_phase_excess_deg"]["value"] == pytest.approx(excess, rel=1e-6)
            assert v["max_phase_excess_deg"]["bound"] == PHASE and v["max_phase_excess_deg"]["op"] == "<="
        robust = all(h["robust"] for h in rep["humans"])
        assert ("robust" in v) == (not robust), a
        for r in (x for x in violations(spec, ev, i, None) if x["constraint"] == "robust"):
            lo, hi = r["range"]
            covered = sum(b - a_ for a_, b in r["stable"]) + sum(b - a_ for a_, b in r["unstable"])
            assert covered == pytest.approx(hi - lo, rel=1e-9)
    assert seen == {True, False}  # both sides of the phase constraint among the rows


def test_exact_latency_margin_is_the_analysis_margin(spec):
    got = exact_latency_margin(spec, np.array([8.0]))
    ref = latency_margin(_cfg(8.0))
    assert got.extra_delay_s == pytest.approx(ref.extra_delay_s, rel=1e-9)
