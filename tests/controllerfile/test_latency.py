"""exotune.controllerfile.latency: the sampled-data latency margin of a controller file
(examples/scheduled.yaml at 1 kHz, tests/controllerfile/conftest.py) against loop matrices built
here (exotune.sampled.closed_loop_matrix at the total delay T + ΔT(1 ∓ 1e-3)): every checked loop
stable just below the margin, the critical member unstable just above, and an independent bisection
of that member's spectral radius in the delay landing on the same margin; the requirement check;
the file's margin is the sweep's engine (exotune.sampled.families) on the file's own realization."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
from exotune.controllerfile.certify import position_feedback, sampled_analysis
from exotune.controllerfile.latency import REL, requirement_problems, sampled_latency_margin
from exotune.sampled import closed_loop_matrix, plant_ss

FAMILIES = (("mass", "inertia"), ("spring", "stiffness"))


def _radius(doc, delay, human=None, env="free"):
    d = copy.deepcopy(doc)
    d["delay_s"]["value"] = float(delay)
    A, B, C = plant_ss(plant_from_file(d), human, env)
    lam = np.linalg.eigvals(closed_loop_matrix(A, B, C, discrete_from_file(d)))
    if env != "locked" and not position_feedback(d["controller"]) and not (human and human.get("stiffness")):
        lam = np.delete(lam, int(np.argmin(np.abs(lam - 1.0))))  # the rigid-body mode
    return float(np.max(np.abs(lam)))


def _loops(doc):
    yield None, "free"
    yield None, "locked"
    for kind, key in FAMILIES:
        lo, hi = {"mass": (0.01, 1.0), "spring": (1.0, 1e4)}[kind]
        for v in np.geomspace(lo, hi, 9):
            yield {key: float(v), "damping": 0.0}, "free"


@pytest.fixture(scope="module")
def margin(scheduled_doc):
    sa = sampled_analysis(scheduled_doc)
    return sampled_latency_margin(scheduled_doc, sa, position_feedback(scheduled_doc["controller"]), sampled_analysis)


def test_ranges_are_the_files(scheduled_doc):
    sa = sampled_analysis(scheduled_doc)
    got = {h["kind"]: h["range"] for h in sa["humans"]}
    assert got["mass"] == [0.01, 1.0] and got["spring"] == [1.0, 10000.0]


def test_stable_just_below_the_margin_and_critical_member_unstable_just_above(scheduled_doc, margin):
    T = float(scheduled_doc["delay_s"]["value"])
    dT = margin["extra_delay_s"]
    assert dT is not None and dT > 0 and margin["confirmed"] is True
    assert margin["extra_delay_samples"] == pytest.approx(dT * 1000.0, rel=1e-12)
    for human, env in _loops(scheduled_doc):
        assert _radius(scheduled_doc, T + dT * (1 - 1e-3), human, env) < 1, (human, env)
    c = margin["critical"]
    assert c["loop"].startswith("human0") and c["parameter"] == "inertia"
    h = {"inertia": c["value"], "damping": 0.0}
    assert _radius(scheduled_doc, T + dT * (1 + 1e-3), h) > 1


def test_independent_bisection_of_the_critical_member_gives_the_margin(scheduled_doc, margin):
    T = float(scheduled_doc["delay_s"]["value"])
    h = {"inertia": margin["critical"]["value"], "damping": 0.0}
    lo, hi = 0.0, 10e-3
    assert _radius(scheduled_doc, T + lo, h) < 1 < _radius(scheduled_doc, T + hi, h)
    while hi - lo > 1e-4 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _radius(scheduled_doc, T + mid, h) < 1 else (lo, mid)
    assert margin["extra_delay_s"] == pytest.approx(0.5 * (lo + hi), rel=2 * REL)


def test_requirement_problems():
    lm = {"required_s": 0.002, "extra_delay_s": 0.0015, "extra_delay_samples": 1.5}
    (p,) = requirement_problems(lm)
    assert "1.5 ms" in p and "< required 2 ms" in p
    assert requirement_problems({**lm, "extra_delay_s": 0.002}) == []
    assert requirement_problems({**lm, "required_s": None}) == []
    assert requirement_problems({**lm, "extra_delay_s": None}) == []


@pytest.mark.parametrize("impl", [{}, {"delay_s": 0.0013}, {"precision": "float32"},
                                  {"precision": "float32", "delay_s": 0.00072, "sample_rate_hz": 2000.0}])
def test_the_file_margin_is_the_sweeps_engine_on_the_files_realization(impl, monkeypatch):
    """One engine: certify's margin of an exported file (its own rounded coefficients; a float32
    file's float32 realization; a fractional-sample delay) and the sweep's sampled column of the
    same design both run exotune.sampled.families.first_crossing, and agree within REL."""
    from exotune.analysis.batch import analyze_batch
    from exotune.config.batch import batch_config
    from exotune.config.yamlio import read_yaml
    from exotune.controllerfile.export import build_export, design_at_rate
    import exotune.sampled.families as families
    from exotune.sweeps.sampledcols import sampled_columns

    calls = []
    engine = families.first_crossing
    monkeypatch.setattr(families, "first_crossing", lambda *a, **k: calls.append(1) or engine(*a, **k))
    raw = read_yaml(Path(__file__).resolve().parents[2] / "examples" / "scheduled.yaml")
    raw.pop("transmission")
    raw["implementation"].update(impl)
    fs = float(raw["implementation"]["sample_rate_hz"])
    cfg = design_at_rate(raw, fs)
    doc = build_export(cfg, fs, analyses=False)
    sa = sampled_analysis(doc)
    lm = sampled_latency_margin(doc, sa, position_feedback(doc["controller"]), sampled_analysis)
    assert calls and lm["confirmed"] is True
    n_file = len(calls)
    b = batch_config(cfg, {})
    sc = sampled_columns(b, analyze_batch(b, latency=True))
    assert len(calls) > n_file
    assert sc["sampled_latency_margin_samples"][0] == pytest.approx(lm["extra_delay_samples"], rel=REL)
    assert lm["extra_delay_samples"] == pytest.approx(lm["extra_delay_s"] * fs, rel=1e-12)
