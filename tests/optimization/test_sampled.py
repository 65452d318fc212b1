"""exotune.optimization.sampled: with a sample rate the optimum is decided on the sampled-data loop.
``verdicts_at`` equals the verdicts of record of the design built here
(exotune.controllerfile.verdicts.design_verdicts); a one-parameter problem (the amplification α of
examples/paper.yaml at 1 kHz with humans from 0.005 kg·m², a tiny budget) returns a design that is
certifiable while α just above it is not (or breaks another constraint), though the continuous
model would accept more; with one sample of latency margin required, where no α of a scan
certifies, the problem is reported infeasible naming the latency margin."""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from exotune.config import design_from_mapping, load_design
from exotune.controllerfile.verdicts import design_verdicts
from exotune.optimization import load_optimize_spec, optimize, optimized_design_mapping
from exotune.optimization.evaluate import evaluate
from exotune.optimization.sampled import POLISH_REL, verdicts_at

ROOT = Path(__file__).resolve().parents[2]
FS = 1000.0
REQ = 1e-3  # s: one sample


def _base():
    raw = copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)
    raw["implementation"].update(delay_s=0.001, sample_rate_hz=FS)
    raw["humans"] = [{"kind": "mass", "inertia": [0.005, 1.0], "damping": 0.0},
                     {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]
    return raw


def _spec(req):
    return load_optimize_spec({"base": _base(), "objective": "amplification",
                               "free": {"design.amplification": [1.5, 60.0]},
                               "constraints": {"latency_margin_s": req}, "budget": 50})


@pytest.fixture(scope="module")
def spec():
    return _spec(0.0)


@pytest.fixture(scope="module")
def solved(spec):
    return optimize(spec)


@pytest.fixture(scope="module")
def at_8_with_margin():
    """``verdicts_at`` at α = 8 with one sample of latency margin required: compared below with the
    verdicts of record of the same design, and one of the α of the infeasibility scan (computed
    once, read by both tests)."""
    return verdicts_at(_spec(REQ), np.array([8.0]))


def test_verdicts_at_are_the_verdicts_of_record_of_the_design(spec, at_8_with_margin):
    raw = _base()
    raw["design"]["amplification"] = 8.0
    ref = design_verdicts(design_from_mapping(raw), require_latency_margin_s=REQ)
    got = at_8_with_margin
    assert got.certifiable == ref.certifiable and got.robust == ref.robust
    assert got.required_latency_margin_s == pytest.approx(REQ, rel=1e-12)
    assert got.latency_margin_s == pytest.approx(ref.latency_margin_s, rel=1e-9)
    for k in ("free_spectral_radius", "locked_spectral_radius"):
        assert got.analysis[k] == pytest.approx(ref.analysis[k], rel=1e-12)


def _other_constraints_ok(spec, x):
    s = dataclasses.replace(spec, constraints={**spec.constraints, "latency_margin_s": 0.0}, latency_deltas=())
    return bool(evaluate(s, x[None, :])["feasible"][0])


def test_optimum_is_certifiable_and_alpha_above_is_not(spec, solved):
    r = solved
    assert r["feasible"] and r["sampled_data"]["certifiable"] and r["sampled_data"]["rounds"] >= 1
    a = r["x"]["design.amplification"]
    assert 1.5 < a < 60.0
    cfg = design_from_mapping(optimized_design_mapping(spec, r))
    v = design_verdicts(cfg)
    assert v.certifiable and v.robust
    up = np.array([a * (1 + 10 * POLISH_REL)])
    others_ok = _other_constraints_ok(spec, up)
    assert not (others_ok and verdicts_at(spec, up).certifiable)
    # the continuous model (exact delay, no hold) accepts α above the sampled-data optimum
    assert others_ok


def test_unreachable_sampled_margin_is_reported_infeasible(at_8_with_margin):
    s = _spec(REQ)
    for a in (1.5, 8.0, 60.0):
        v = at_8_with_margin if a == 8.0 else verdicts_at(s, np.array([a]))  # the same call at α = 8
        assert not v.certifiable
    r = optimize(s)
    assert r["feasible"] is False and "latency_margin_s" in r["broken"]
