"""optimize's search judges every gain-schedule entry (paper §IV gain scheduling), as analyze,
export and certify do: a candidate whose entry is unstable is infeasible by the name
``gain_schedule`` (not blamed on the latency margin), and the latency-margin constraint holds for
the smallest of the entries' margins at the optimum."""

from __future__ import annotations

import copy

import pytest

from exotune.analysis.latency_margin import latency_margin, schedule_latency_margin
from exotune.config import design_from_mapping, read_yaml
from exotune.optimization import optimize
from exotune.optimization.spec import DEFAULT_LATENCY_MARGIN_S, load_optimize_spec


def _raw(delay, transmission=None):
    raw = read_yaml("examples/scheduled.yaml")
    raw["implementation"]["sample_rate_hz"] = None  # the continuous search and its exact final check
    raw["implementation"]["delay_s"] = delay
    if transmission is None:
        del raw["transmission"]
    else:
        raw["transmission"] = transmission
    return raw


def test_an_unstable_entry_is_named():
    raw = _raw(0.003, {"joint_angle_rad": [0.0, 1.0], "ratio": [1.0, 2.0]})
    # the main controller is robust for every amplification in [4, 20]; the ratio-2 entry never is
    spec = load_optimize_spec({"base": raw, "free": {"design.amplification": [4.0, 20.0]},
                               "objective": "amplification", "budget": 60, "seed": 0})
    out = optimize(spec)
    assert out["feasible"] is False
    assert "gain_schedule" in out["broken"]
    entries = [v for v in out["violations"] if v["constraint"] == "gain_schedule"]
    assert [(v["joint_angle_rad"], v["ratio"]) for v in entries] == [(1.0, 2.0)]
    assert "human0_mass" in entries[0]["loops"]


def test_the_latency_constraint_holds_for_every_entry():
    sched = {"joint_angle_rad": [0.0, 1.0, 2.0], "ratio": [0.85, 1.0, 1.25]}
    got = {}
    for name, tr in (("scheduled", sched), ("plain", None)):
        spec = load_optimize_spec({"base": _raw(0.0025, tr), "free": {"design.felt_inertia": [0.02, 0.5]},
                                   "objective": "felt_inertia", "budget": 120, "seed": 1})
        out = optimize(spec)
        assert out["feasible"] is True
        got[name] = out["x"]["design.felt_inertia"]
    raw = _raw(0.0025, sched)
    raw["design"]["felt_inertia"] = got["scheduled"]
    cfg = design_from_mapping(copy.deepcopy(raw))
    worst, entries = schedule_latency_margin(cfg, latency_margin(cfg))
    assert worst.extra_delay_s >= DEFAULT_LATENCY_MARGIN_S * (1 - 1e-6)
    assert worst.gain_schedule_entry == (2.0, 1.25)  # the 1.25 entry binds, not the main controller
    # without the schedule the optimum is lighter: there the main controller's margin binds, and
    # that design's 1.25 entry would not tolerate the required extra delay
    assert got["plain"] < got["scheduled"]
    raw["design"]["felt_inertia"] = got["plain"]
    cfg = design_from_mapping(copy.deepcopy(raw))
    assert schedule_latency_margin(cfg, latency_margin(cfg))[0].extra_delay_s < DEFAULT_LATENCY_MARGIN_S
    assert got["scheduled"] == pytest.approx(got["plain"], rel=0.2)


def test_metric_constraints_judge_the_worst_entry():
    """A bound on a metric (passivity, DOB margins, bandwidth, amplification peak) must hold for
    every controller the runtime runs: the evaluation's value is the worst over the main
    controller and the entries, each analysed here from a hand-reflected design file."""
    import numpy as np

    from exotune.analysis import analyze_batch
    from exotune.optimization.evaluate import column, evaluate
    from exotune.optimization.peak import amplification_peak
    from reflected_design import by_hand

    tr = {"joint_angle_rad": [0.0, 2.0], "ratio": [0.85, 1.25]}
    raw = _raw(0.001, tr)
    spec = load_optimize_spec({"base": raw, "free": {"design.amplification": [4.0, 20.0]},
                               "objective": "amplification_bandwidth_hz",
                               "constraints": {"max_phase_excess_deg": 4.0, "amplification_peak_db": 3.0,
                                               "dob_phase_margin_deg": 20.0}, "budget": 50})
    alphas = np.array([5.0, 12.0])
    ev = evaluate(spec, alphas[:, None])
    for i, a in enumerate(alphas):
        refs = [analyze_batch(by_hand(raw, r, a)) for r in (1.0, *tr["ratio"])]
        peaks = [float(amplification_peak(by_hand(raw, r, a))[0][0]) for r in (1.0, *tr["ratio"])]
        pe = [float(x.passivity.max_phase_excess_deg[0]) for x in refs]
        bw = [float(x.amplification.bandwidth_hz[0]) for x in refs]
        pm = [float(x.dob.phase_margin_deg[0]) for x in refs]
        assert column(ev, "passivity_max_phase_excess_deg")[i] == pytest.approx(max(pe), rel=1e-9)
        assert column(ev, "amplification_peak_db")[i] == pytest.approx(max(peaks), rel=1e-9)
        assert column(ev, "dob_phase_margin_deg")[i] == pytest.approx(min(pm), rel=1e-9)
        assert ev["objective"][i] == pytest.approx(min(bw), rel=1e-9)  # the worst bandwidth is maximized
        assert bool(ev["broken"]["max_phase_excess_deg"][i]) == (max(pe) > 4.0)
    # the entries matter here: the worst is not the main controller's for every metric
    main = [float(analyze_batch(by_hand(raw, 1.0, a)).amplification.bandwidth_hz[0]) for a in alphas]
    assert any(ev["objective"][i] < main[i] * (1 - 1e-6) for i in range(alphas.size))
