"""exotune.analysis.amplification_ratio: the DC value and first −3 dB frequency of the strength
amplification C6/C5 against a dense frequency sweep of C6/C5 built by the paper's system algebra
(exotune.model.plant.seven_systems on the implemented blocks, designs without DOB) or of the
quasi-polynomial ratio (designs with DOB)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.analysis.amplification_ratio import amplification, dc_and_bandwidth
from exotune.model.controller import build_controller
from tests.paper_design import paper_design
from tests.system_algebra import amplification_magnitude

F = np.geomspace(1e-3, 1e4, 200_001)


def _cfg(dob, **design):
    cfg = paper_design() if dob else paper_design(dob=None)
    return dataclasses.replace(cfg, design=dataclasses.replace(cfg.design, **design)) if design else cfg


def _sweep(cfg, f=F):
    return amplification_magnitude(cfg, f)


def _first_crossing_hz(mag, dc, f=F):
    below = np.nonzero(mag <= dc / np.sqrt(2))[0]
    return np.inf if below.size == 0 else f[below[0]]


@pytest.mark.parametrize("dob,design", [(False, {}), (False, {"amplification": 3.0, "zeta_hat": 0.5}),
                                        (True, {}), (True, {"amplification": 20.0})])
def test_dc_and_bandwidth_against_a_dense_sweep(dob, design):
    cfg = _cfg(dob, **design)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    a = amplification(cfg.plant, cs, 1)
    mag = _sweep(cfg)
    assert a["dc"][0] == pytest.approx(mag[0], rel=1e-6)
    bw = float(a["bandwidth_hz"][0])
    ref = _first_crossing_hz(mag, a["dc"][0])
    assert np.isfinite(bw) and np.isfinite(ref)
    assert bw == pytest.approx(ref, rel=2e-4)  # the sweep's spacing is 8e-5 relative
    assert a["locked_stable"][0] and a["conclusive"][0]
    # the DC value is the paper design's amplification (the design target, paper §II-D)
    assert a["dc"][0] == pytest.approx(float(cfg.design.amplification), rel=1e-6)


def test_a_ratio_that_never_falls_has_an_infinite_bandwidth():
    from exotune.numerics.quasipoly import QP

    one = QP(np.array([[2.0, 1.0]]), np.zeros((1, 1)), 0.0)
    dc, bw = dc_and_bandwidth(one, one)
    assert dc[0] == pytest.approx(1.0) and bw[0] == np.inf


@settings(max_examples=20, deadline=None)
@given(k=st.floats(0.5, 20.0), p=st.floats(0.1, 100.0))
def test_a_first_order_ratio_has_its_pole_as_bandwidth(k, p):
    """num/den = k p/(s + p): dc = k, −3 dB at ω = p."""
    from exotune.numerics.quasipoly import QP

    num = QP(np.array([[k * p]]), np.zeros((1, 1)), 0.0)
    den = QP(np.array([[p, 1.0]]), np.zeros((1, 1)), 0.0)
    dc, bw = dc_and_bandwidth(num, den)
    assert dc[0] == pytest.approx(k, rel=1e-9)
    assert bw[0] == pytest.approx(p / (2 * np.pi), rel=1e-6)


def test_batched_verdicts_equal_single_designs():
    cfg = _cfg(True)
    alphas = np.array([3.0, 10.0, 30.0])
    d = dataclasses.replace(cfg.design, amplification=alphas)
    cs, _ = build_controller(cfg.plant, d, cfg.implementation)
    batch = amplification(cfg.plant, cs, 3)
    for i, al in enumerate(alphas):
        cs1, _ = build_controller(cfg.plant, dataclasses.replace(cfg.design, amplification=al), cfg.implementation)
        one = amplification(cfg.plant, cs1, 1)
        for k in ("dc", "bandwidth_hz"):
            assert batch[k][i] == pytest.approx(one[k][0], rel=1e-9)
        for k in ("minimum_phase", "locked_stable", "conclusive"):
            assert batch[k][i] == one[k][0]


def test_both_engines_find_the_first_crossing_before_a_long_delay_winding():
    """An extreme design (29.6 ms delay, the −3 dB level at 7.2 Hz, the delay's phase winding up
    to the search's 10⁹ rad/s): the compiled search goes left to right and stops at the first
    −3 dB crossing; the numpy reference refines level by level and used to spend its budget on
    the range beyond the crossing and report the bandwidth undefined (NaN). It now refines
    nothing right of a leaf that brackets the first crossing: the same bandwidth in both."""
    from exotune.analysis.batch import analyze_batch
    from exotune.config import batch_config, load_design
    from exotune.numerics.engine import numpy_engine

    design = {"plant.motor_inertia": 0.00010294999468113419, "plant.motor_damping": 6.9162747754371106,
              "plant.sea_stiffness": 91.46899571009024, "plant.joint_inertia": 3.4419044324681547,
              "plant.cuff_stiffness": 327.55838921413925, "design.amplification": 6.424915459186619,
              "design.felt_inertia": 0.00012049691715046248, "design.felt_damping": 56.673529217156776,
              "design.zeta": 0.013950582764259277, "design.zeta_hat": 89.92893461867502,
              "implementation.delay_s": 0.029592385513960626}
    cfg = batch_config(load_design("examples/paper.yaml"), {k: np.array([v]) for k, v in design.items()})
    with np.errstate(all="ignore"):
        a = analyze_batch(cfg).amplification.bandwidth_hz[0]
        with numpy_engine():
            b = analyze_batch(cfg).amplification.bandwidth_hz[0]
    assert np.isfinite(a) and a == pytest.approx(7.2475, rel=1e-4)
    assert b == pytest.approx(a, rel=1e-9)


def test_the_numpy_search_rescans_left_to_right_when_its_budget_is_spent():
    """Three extreme designs (a 0.59 s delay winding up to the search's top frequency; a −3 dB
    level at 6.6e-4 Hz; a crossing at 4e5 Hz inside a grid cell that alone needs half the budget):
    the numpy reference, refining level by level, spent its leaf budget before it had bracketed the
    first −3 dB crossing and reported the bandwidth undefined (NaN) where the compiled left-to-right
    search found it. The spent tasks are now searched again from the left, a cell at a time and a
    cell that would spend the rest of the budget in halves: the same bandwidth in both engines, at
    dc/√2 and with |C6/C5| above the level on a dense grid below it."""
    from exotune.analysis.charfun import amplification_qps
    from exotune.config import batch_config, load_design
    from exotune.numerics.engine import numpy_engine

    designs = [
        {"plant.motor_inertia": 2.277063130143581, "plant.motor_damping": 0.24111069774415736,
         "plant.sea_stiffness": 1115.2353558422326, "plant.joint_inertia": 139.72668728019983,
         "plant.cuff_stiffness": 311592.3914445048, "design.amplification": 1109.553832318745,
         "design.felt_inertia": 5.502103757453938e-05, "design.felt_damping": 0.0007181494064485406,
         "design.zeta": 73.41484458868145, "design.zeta_hat": 0.47157095047520586,
         "implementation.delay_s": 0.5933039590287728},
        {"plant.motor_inertia": 0.00010740719051431116, "plant.motor_damping": 15165.186841326125,
         "plant.sea_stiffness": 137.4566347415377, "plant.joint_inertia": 9.701210095778573e-06,
         "plant.cuff_stiffness": 6501706.630247029, "design.amplification": 1243.8066023360318,
         "design.felt_inertia": 748.334659231224, "design.felt_damping": 74.22892164139893,
         "design.zeta": 1.9083506187247399, "design.zeta_hat": 4.424770325137179,
         "implementation.delay_s": 0.00031680717780757634},
        {"plant.motor_inertia": 0.38363909090996356, "plant.motor_damping": 2.5247609592203597,
         "plant.sea_stiffness": 72.18186012144703, "plant.joint_inertia": 34.07348545647694,
         "plant.cuff_stiffness": 0.8060079725553395, "design.amplification": 8.301843150694715,
         "design.felt_inertia": 0.10739228734581596, "design.felt_damping": 712.0487711774216,
         "design.zeta": 0.010998511437691162, "design.zeta_hat": 0.003449926289213124,
         "implementation.delay_s": 0.01905597829941735},
    ]
    cfg = batch_config(load_design("examples/paper.yaml"), {k: np.array([d[k] for d in designs]) for k in designs[0]})
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    num, den = amplification_qps(cfg.plant, cs, 3)
    with np.errstate(all="ignore"):
        dc, bw = dc_and_bandwidth(num, den)
        with numpy_engine():
            dc_np, bw_np = dc_and_bandwidth(num, den)
    assert np.all(np.isfinite(bw)) and bw_np == pytest.approx(bw, rel=1e-9)
    level = np.abs(dc) / np.sqrt(2)
    for i in range(3):
        w = 2 * np.pi * np.r_[np.geomspace(bw[i] * 1e-6, bw[i], 100_000)[:-1], bw[i]]
        rows = np.full(w.size, i)
        mag = np.abs(num.eval(rows, w, deriv=False)[0] / den.eval(rows, w, deriv=False)[0])
        assert mag[-1] == pytest.approx(level[i], rel=1e-6)
        assert np.all(mag[:-1] >= level[i] * (1 - 1e-6))
