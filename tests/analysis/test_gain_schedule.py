"""The gain schedule of a batch (exotune.analysis.gain_schedule): every entry of every design is
the design with its plant section reflected by ratio² (paper §IV gain scheduling), checked here
against design files whose plant sections are reflected by hand, one file per entry and design."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from exotune.analysis import analyze_batch, analyze_with_margins
from exotune.analysis.gain_schedule import analyze_schedule
from exotune.config import batch_config, design_from_mapping, read_yaml
from reflected_design import by_hand

ALPHAS = np.array([3.0, 8.0, 20.0])


def _raw(ratios=(1.0, 2.0), delay=0.003):
    raw = read_yaml("examples/scheduled.yaml")
    raw["implementation"]["sample_rate_hz"] = None
    raw["implementation"]["delay_s"] = delay
    raw["transmission"] = {"joint_angle_rad": [0.5 * i for i in range(len(ratios))], "ratio": list(ratios)}
    return raw


def _by_hand(raw, alpha, ratio):
    return by_hand(raw, ratio, alpha)


@pytest.fixture(scope="module")
def batch():
    raw = _raw()
    cfg = batch_config(design_from_mapping(copy.deepcopy(raw)), {"design.amplification": ALPHAS})
    return raw, analyze_schedule(cfg, latency=True)


def test_entries_are_the_hand_reflected_designs(batch):
    raw, sched = batch
    assert sched.n == ALPHAS.size and sched.ratio == (1.0, 2.0) and sched.joint_angle_rad == (0.0, 0.5)
    for e, ratio in enumerate(sched.ratio):
        ent = sched.entry(e)
        for i, a in enumerate(ALPHAS):
            ref = analyze_batch(_by_hand(raw, a, ratio), latency=True)
            assert bool(ent.loops_ok()[i]) == bool(ref.loops_ok()[0])
            assert ent.gain_values(i) == pytest.approx(ref.gain_values(0), rel=1e-12)
            for h, hr in zip(ent.humans, ref.humans):
                assert np.allclose(np.asarray(h.stable_intervals[i], float).ravel(),
                                   np.asarray(hr.stable_intervals[0], float).ravel(), rtol=1e-9)
            assert ent.latency_margin_s[i] == pytest.approx(ref.latency_margin_s[0], rel=1e-9, abs=1e-12)


def test_reductions_over_the_entries(batch):
    raw, sched = batch
    ok = np.array([[bool(analyze_batch(_by_hand(raw, a, r)).loops_ok()[0]) for a in ALPHAS] for r in sched.ratio])
    assert (sched.loops_ok() == ok).all()
    assert (sched.robust() == ok.all(axis=0)).all()
    assert (sched.failing_entries() == (~ok).sum(axis=0)).all()
    # the 2.0 entry is unstable at a 3 ms delay for every alpha here, the nominal one is not
    assert not sched.robust().any() and ok[0, 1:].all()
    m = np.array([[analyze_batch(_by_hand(raw, a, r), latency=True).latency_margin_s[0] for a in ALPHAS]
                  for r in sched.ratio])
    assert np.allclose(sched.latency_margin_s(), m.min(axis=0), rtol=1e-9, atol=1e-12)


def test_columns_take_the_smallest_margin():
    raw = _raw(ratios=(0.85, 1.25), delay=0.001)
    cfg = batch_config(design_from_mapping(copy.deepcopy(raw)), {"design.amplification": ALPHAS})
    nominal = analyze_batch(cfg, latency=True)
    sched = analyze_schedule(cfg, latency=True)
    cols = sched.to_columns(nominal)
    assert cols["schedule_robust"].all() and (cols["schedule_failing_entries"] == 0).all()
    want = np.minimum(nominal.latency_margin_s, sched.latency_margin_s())
    assert np.array_equal(cols["latency_margin_s"], want)
    assert np.array_equal(cols["latency_margin_main_s"], nominal.latency_margin_s)
    # the 1.25 entry is the smallest here: the main controller's margin is larger
    assert (cols["latency_margin_s"] < cols["latency_margin_main_s"]).all()


def test_single_design_report_is_the_same_engine():
    raw = _raw()
    raw["design"]["amplification"] = 8.0
    rep = analyze_with_margins(design_from_mapping(copy.deepcopy(raw)), sampled_check=False)
    assert [(e.ratio, e.robust) for e in rep.gain_schedule] == [(1.0, True), (2.0, False)]
    assert rep.gain_schedule[1].not_robust == ("human0_mass",)


def test_no_schedule_is_none():
    raw = _raw()
    del raw["transmission"]
    assert analyze_schedule(design_from_mapping(raw)) is None


def test_worst_metric_columns_are_the_worst_of_the_hand_reflected_designs():
    """``schedule_worst_*`` (docs/sweep-spec.md#gain-schedule): the worst over the main controller
    and every entry, each analysed on its own from a plant reflected by hand."""
    from exotune.analysis.gain_schedule import WORST_METRICS

    raw = _raw(ratios=(0.85, 1.25), delay=0.001)
    cfg = batch_config(design_from_mapping(copy.deepcopy(raw)), {"design.amplification": ALPHAS})
    cols = analyze_schedule(cfg).to_columns(analyze_batch(cfg))
    changed = set()
    for i, a in enumerate(ALPHAS):
        refs = [analyze_batch(_by_hand(raw, a, r)).to_columns() for r in (1.0, 0.85, 1.25)]
        for col, op in WORST_METRICS.items():
            vals = [float(np.asarray(c[col])[0]) for c in refs]
            want = max(vals) if op == "<=" else min(vals)
            assert cols[f"schedule_worst_{col}"][i] == pytest.approx(want, rel=1e-9), col
            if want != vals[0]:
                changed.add(col)
        assert bool(cols["schedule_passivity_conclusive"][i]) == all(bool(c["passivity_conclusive"][0]) for c in refs)
    # an entry, not the main controller, is the worst for the passivity excess and the bandwidth here
    assert {"passivity_max_phase_excess_deg", "amplification_bandwidth_hz"} <= changed


def test_worst_over_rows():
    from exotune.analysis.gain_schedule import worst_over

    v = np.array([[1.0, 5.0, np.nan, 2.0], [3.0, 4.0, 1.0, -np.inf], [0.5, 6.0, 2.0, 0.0]])
    lo, k = worst_over(v, ">=")
    assert np.array_equal(lo[[0, 1, 3]], [0.5, 4.0, -np.inf]) and np.isnan(lo[2])
    assert list(k[[0, 1, 3]]) == [2, 1, 1]
    hi, k = worst_over(v, "<=")
    assert np.array_equal(hi[[0, 1, 3]], [3.0, 6.0, 2.0]) and np.isnan(hi[2])
    assert list(k[[0, 1, 3]]) == [1, 2, 0]
    with pytest.raises(ValueError, match="op"):
        worst_over(v, "==")
