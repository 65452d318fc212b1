"""exotune.numerics.kernels.leaves: the compiled adaptive frequency set of two tracked
quasi-polynomials. Its leaves tile each task's grid, carry the values of both functions at their
ends (QP.eval), satisfy the acceptance rule (phase step < ARG_STEP for both), and sum to the phase
change of the numpy reference (quasipoly.leaves_pair / phase_sums with the numpy engine)."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.numerics.kernels import AVAILABLE, leaves
from exotune.numerics.quasipoly import ARG_STEP, DER_STEP, MAX_LEVELS, QP, leaves_pair, log_grid, omega_max, phase_sums

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed")


def _setup(seed=0, n=12):
    rng = np.random.default_rng(seed)
    T = rng.uniform(1e-3, 2e-2, n)
    a0 = np.abs(rng.normal(size=(n, 6))) + 0.1
    a1 = rng.normal(size=(n, 4))
    b0 = np.abs(rng.normal(size=(n, 5))) + 0.1
    b1 = rng.normal(size=(n, 3))
    qa, qb = QP(a0, a1, T), QP(b0, b1, T)
    wm = np.maximum(omega_max(a0, a1, engine="numpy"), omega_max(b0, b1, engine="numpy"))
    valid = np.isfinite(wm)
    valid[0] = False  # a task not refined
    grid = log_grid(np.where(valid, wm, 1.0), decades=6, per_decade=2)
    return qa, qb, grid, valid


def test_leaves_tile_the_grid_and_satisfy_the_acceptance_rule():
    qa, qb, grid, valid = _setup()
    lv = leaves.leaves2(qa, qb, grid, valid, ARG_STEP, DER_STEP, MAX_LEVELS)
    assert lv["resolved"][valid].all() and not lv["exhausted"].any()
    assert not np.isin(0, lv["task"])  # the task not refined has no leaves
    for t in np.nonzero(valid)[0]:
        m = lv["task"] == t
        a, b = lv["a"][m], lv["b"][m]
        o = np.argsort(a)
        a, b = a[o], b[o]
        assert a[0] == grid[t, 0] and b[-1] == pytest.approx(grid[t, -1], rel=1e-15)
        np.testing.assert_allclose(a[1:], b[:-1], rtol=1e-15)  # contiguous, no overlap
        assert np.all(b > a)
    task = lv["task"]
    for q, (va, vb) in ((qa, (lv["va"][0], lv["vb"][0])), (qb, (lv["va"][1], lv["vb"][1]))):
        np.testing.assert_allclose(va, q.eval(task, lv["a"], deriv=False)[0], rtol=1e-11)
        np.testing.assert_allclose(vb, q.eval(task, lv["b"], deriv=False)[0], rtol=1e-11)
        assert np.all(np.abs(np.angle(vb / va)) < ARG_STEP + 1e-12)


def test_phase_changes_equal_the_numpy_reference():
    qa, qb, grid, valid = _setup(1)
    lv = leaves.leaves2(qa, qb, grid, valid, ARG_STEP, DER_STEP, MAX_LEVELS)
    ref = leaves_pair(qa, qb, grid, valid, engine="numpy")
    np.testing.assert_array_equal(lv["resolved"][valid], ref["resolved"][valid])
    for i, q in enumerate((qa, qb)):
        steps = np.bincount(lv["task"], weights=np.angle(lv["vb"][i] / lv["va"][i]), minlength=q.n)
        ref_steps = np.bincount(ref["task"], weights=np.angle(ref["vb"][i] / ref["va"][i]), minlength=q.n)
        np.testing.assert_allclose(steps[valid], ref_steps[valid], rtol=0, atol=1e-9)
        tot, _ = phase_sums(q, grid, valid, engine="numpy")
        np.testing.assert_allclose(steps[valid], tot[valid], rtol=0, atol=1e-9)


def test_the_magnitude_criterion_stops_at_the_first_down_crossing():
    """With lthr (log of the −3 dB level per task) a task's leaves tile its grid from the start up
    to the first leaf where |a/b| falls through the level, and that leaf holds the first crossing
    of a dense sweep (the bandwidth of exotune.analysis.amplification_ratio)."""
    qa, qb, grid, valid = _setup(2)
    v0a = qa.eval(np.arange(qa.n), np.zeros(qa.n), deriv=False)[0]
    v0b = qb.eval(np.arange(qb.n), np.zeros(qb.n), deriv=False)[0]
    lev = np.abs(v0a / v0b) / np.sqrt(2.0)
    lv = leaves.leaves2(qa, qb, grid, valid, ARG_STEP, DER_STEP, MAX_LEVELS, lthr=np.log(lev))
    crossed = 0
    for t in np.nonzero(valid)[0]:
        m = lv["task"] == t
        a, b = lv["a"][m], lv["b"][m]
        ra = np.abs(lv["va"][0][m] / lv["va"][1][m])
        rb = np.abs(lv["vb"][0][m] / lv["vb"][1][m])
        assert a[0] == grid[t, 0]
        np.testing.assert_allclose(a[1:], b[:-1], rtol=1e-15)
        down = np.nonzero((ra > lev[t]) & (rb < lev[t]))[0]
        w = np.concatenate([[0.0], np.logspace(np.log10(grid[t, 1]), np.log10(grid[t, -1]), 200001)])
        r = np.abs(qa.eval(np.full(w.size, t), w, deriv=False)[0] / qb.eval(np.full(w.size, t), w, deriv=False)[0])
        below = np.nonzero(r < lev[t])[0]
        if down.size == 0:
            assert b[-1] == pytest.approx(grid[t, -1], rel=1e-15) and below.size == 0
            continue
        crossed += 1
        assert down[0] == a.size - 1  # the task stops at its first down-crossing
        k = below[0]  # the dense sweep's first point below the level: the crossing is in (w[k−1], w[k]]
        assert w[k - 1] < b[-1] and w[k] > a[-1]
    assert crossed >= 3
