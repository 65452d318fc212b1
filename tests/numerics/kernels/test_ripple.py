"""exotune.numerics.kernels.ripple: the compiled frozen-ripple frame of C7 = Δ10/Δ00 against the
numpy reference (exotune.analysis.operator_passivity._frame), the algebraic identity that defines
G, and the bound that makes the frame safe: wherever C7 is non-passive by more than
(π/2)·RIPPLE_MIN_DEG, the frame says the ripple can lift the phase that far. The compiled sampling
pass (c7_samples) against the numpy reference (operator_passivity._samples) on the campaign designs
and a random batch around the paper example."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import campaign_designs
from exotune.analysis import operator_passivity as op
from exotune.analysis.charfun import char_terms
from exotune.analysis.intervals import FamilySide
from exotune.config import batch_config, design_from_mapping
from exotune.model.controller import build_controller
from exotune.numerics.engine import numpy_engine
from exotune.numerics.kernels import AVAILABLE, c7_samples, ripple_frame
from exotune.numerics.quasipoly import DIP_RISE_UNEVEN, QP

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed")


def _pair(rng, n):
    """Random Δ00 (retarded, positive leading coefficients) and Δ10 with equal delays."""
    a0 = np.abs(rng.normal(size=(n, 6))) + 0.1
    a1 = rng.normal(size=(n, 4))
    b0 = np.abs(rng.normal(size=(n, 6))) + 0.1
    b1 = rng.normal(size=(n, 4))
    T = rng.uniform(1e-3, 2e-2, n)
    T[0] = 0.0  # a design without delay: no ripple
    return QP(a0, a1, T), QP(b0, b1, T)


def _samples(D0, D1, n, per=400):
    task = np.repeat(np.arange(n), per)
    w = np.tile(np.geomspace(0.05, 3e3, per), n)
    return task, w, D0.eval(task, w, deriv=False)[0], D1.eval(task, w, deriv=False)[0]


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_compiled_frame_equals_numpy_and_g_satisfies_its_identity(seed):
    rng = np.random.default_rng(seed)
    D0, D1 = _pair(rng, 5)
    task, w, d0, d1 = _samples(D0, D1, 5)
    flag, g = ripple_frame(D0, D1, task, w, d0, d1, op.RIPPLE_MIN_DEG)
    with numpy_engine():
        flag_np, g_np = op._frame(D0, D1, task, w, d0, d1)
    np.testing.assert_allclose(g, g_np, rtol=1e-9, atol=1e-12 * np.max(np.abs(g_np)))
    # the flags agree except where the lift sits on the threshold to rounding
    assert np.mean(flag != flag_np) < 1e-3
    nod = D0.T[task] == 0
    assert not flag[nod].any() and not np.any(g[nod])
    # |Δ00|² Im C7 = A0 + Im(G e^{−jωT}) with A0 = Im(P10 conj P00 + P11 conj P01)
    d = ~nod
    t_, x = task[d], w[d]
    e = np.exp(-1j * x * D0.T[t_])
    p00, p01 = D0.parts(t_, x)
    p10, p11 = D1.parts(t_, x)
    a0 = np.imag(p10 * np.conj(p00) + p11 * np.conj(p01))
    lhs = np.abs(d0[d]) ** 2 * np.imag(d1[d] / d0[d])
    scale = np.abs(d0[d]) * np.abs(d1[d]) + np.abs(a0) + np.abs(g[d])
    np.testing.assert_allclose(lhs, a0 + np.imag(g[d] * e), rtol=0, atol=1e-10 * np.max(scale))


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_frame_flags_every_sample_that_is_non_passive_enough(seed):
    """sin(excess) ≤ (A0 + |G|)/(|Δ00||Δ10|) ≤ the frame's lift bound, so an excess ≥ (π/2)·lift
    threshold must be flagged (the ripple sampling never skips a cell that is visibly non-passive)."""
    rng = np.random.default_rng(seed)
    D0, D1 = _pair(rng, 5)
    task, w, d0, d1 = _samples(D0, D1, 5)
    flag, _ = ripple_frame(D0, D1, task, w, d0, d1, op.RIPPLE_MIN_DEG)
    ph = np.degrees(np.angle(d1 / d0))
    excess = np.where(ph > 0, np.minimum(ph, 180.0 - ph), 0.0)
    must = (excess >= (np.pi / 2) * op.RIPPLE_MIN_DEG * (1 + 1e-9)) & (D0.T[task] > 0)
    assert must.any()
    assert flag[must].all()


_PASSIVITY_DESIGNS = ["RIPPLE_LOBES", "NARROW_PASSIVITY_BAND", "PHASE_THROUGH_90", "PASSIVITY_GAP", "LOBE_NEAR_180",
                      "BAND_END_NEAR_RESOLUTION"]


def _leaves(cfg, n):
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    return FamilySide(char_terms(cfg.plant, cs, n), "00", "10", []).compute_leaves((0.0, 0.0, 0.0))


def _batches():
    for name in _PASSIVITY_DESIGNS:
        yield name, _leaves(batch_config(design_from_mapping(getattr(campaign_designs, name)), {}), 1)
    rng = np.random.default_rng(5)
    n = 300
    base = design_from_mapping(campaign_designs.RIPPLE_LOBES)
    axes = {"design.amplification": rng.uniform(1.5, 20.0, n), "design.zeta_hat": rng.uniform(0.3, 1.2, n),
            "implementation.delay_s": np.r_[0.0, rng.uniform(0.0, 0.006, n - 1)]}
    yield "random", _leaves(batch_config(base, axes), n)


@pytest.mark.parametrize("name, leaves", list(_batches()), ids=lambda x: x if isinstance(x, str) else "")
def test_compiled_samples_equal_the_numpy_reference(name, leaves):
    """Same samples (design, count, order), the same partial-coverage flags, frequencies and C7 to
    rounding; the points found between samples (lobes, gaps) come from golden-section searches
    whose flat optimum both engines locate only to about 1e-5 relative, but with the same sign of
    Im C7 (that sign is what the bands are built on)."""
    D0, D1, lv = leaves
    task, w, c, over = c7_samples(D0, D1, lv, op.RIPPLE_MIN_DEG, op.TAIL_STEPS, op.MAX_RIPPLE_SAMPLES, DIP_RISE_UNEVEN)
    with numpy_engine():
        task_np, w_np, c_np, over_np = op._samples(D0, D1, lv)
    np.testing.assert_array_equal(task, task_np)
    np.testing.assert_array_equal(over, over_np)
    np.testing.assert_allclose(w, w_np, rtol=1e-4)
    close = np.isclose(w, w_np, rtol=1e-12, atol=0)
    assert close.mean() > 0.99
    np.testing.assert_allclose(c[close], c_np[close], rtol=1e-8, atol=0)
    resolved = np.abs(c_np.imag) > 1e-6 * np.abs(c_np)
    np.testing.assert_array_equal(np.sign(c.imag[resolved]), np.sign(c_np.imag[resolved]))
    assert np.all(np.diff(w)[task[1:] == task[:-1]] >= 0)  # ordered by frequency within a design
    if name in ("RIPPLE_LOBES", "random"):
        assert task.size > lv["task"].size + D0.n  # the ripple points are there


def test_degenerate_samples_neither_raise_nor_differ_from_the_numpy_reference():
    """C7 = 0 at a sample (Δ10 = 0: sin arg C7 is 0/0), an empty cell (a leaf of zero length) and a
    non-finite value: numba's float division by zero raises where numpy gives NaN; the compiled
    pass must give the reference's samples."""
    D0, D1, lv = _leaves(batch_config(design_from_mapping(campaign_designs.RIPPLE_LOBES), {}), 1)
    lv = {k: (list(v) if k in ("va", "vb") else v) for k, v in lv.items()}
    n = lv["task"].size
    ins = n // 2
    lv["task"] = np.insert(lv["task"], ins, lv["task"][ins])  # a leaf of zero length
    lv["a"] = np.insert(lv["a"], ins, lv["a"][ins])
    lv["b"] = np.insert(lv["b"], ins, lv["a"][ins])
    lv["va"] = [np.insert(v, ins, v[ins]) for v in lv["va"]]
    lv["vb"] = [np.insert(v, ins, v[ins]) for v in lv["vb"]]
    lv["vb"][1] = lv["vb"][1].copy()
    lv["vb"][1][ins + 3] = 0.0  # C7 = 0 at a sample
    lv["vb"][0] = lv["vb"][0].copy()
    lv["vb"][0][ins + 6] = np.nan  # a non-finite Δ00
    task, w, c, over = c7_samples(D0, D1, lv, op.RIPPLE_MIN_DEG, op.TAIL_STEPS, op.MAX_RIPPLE_SAMPLES, DIP_RISE_UNEVEN)
    with numpy_engine(), np.errstate(all="ignore"):
        task_np, w_np, c_np, over_np = op._samples(D0, D1, lv)
    np.testing.assert_array_equal(task, task_np)
    np.testing.assert_array_equal(over, over_np)
    np.testing.assert_allclose(w, w_np, rtol=1e-4)
    assert np.sum(c == 0) == np.sum(c_np == 0) >= 1
    assert np.sum(np.isnan(c)) == np.sum(np.isnan(c_np)) >= 1


@pytest.mark.parametrize("max_ripple", [1, 3, 10])
def test_a_design_over_the_ripple_budget_has_partial_coverage_in_both_engines(monkeypatch, max_ripple):
    """More ripple points than the budget: no ripple points and the partial-coverage flag (NaN
    maximum, no bands), in the compiled pass as in the reference (the compiled pass once dropped
    the points without raising the flag)."""
    D0, D1, lv = _leaves(batch_config(design_from_mapping(campaign_designs.RIPPLE_LOBES), {}), 1)
    monkeypatch.setattr(op, "MAX_RIPPLE_SAMPLES", max_ripple)
    task, w, c, over = c7_samples(D0, D1, lv, op.RIPPLE_MIN_DEG, op.TAIL_STEPS, max_ripple, DIP_RISE_UNEVEN)
    with numpy_engine():
        task_np, w_np, c_np, over_np = op._samples(D0, D1, lv)
    assert over[0] and over_np[0]
    np.testing.assert_array_equal(task, task_np)
    np.testing.assert_allclose(w, w_np, rtol=1e-4)
    res = op.passivity(_Side(D0, D1, lv))
    assert np.isnan(res.max_phase_excess_deg[0]) and res.nonpassive_band_hz[0] == []


class _Side:
    """The human side as passivity reads it: its leaves at z0 = 0."""

    def __init__(self, D0, D1, lv):
        self.leaves = {(0.0, 0.0, 0.0): (D0, D1, lv)}
