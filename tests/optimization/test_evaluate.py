"""exotune.optimization.evaluate: the evaluation of candidate designs equals analyze_batch's
columns for those designs, its feasibility follows the constraints, and the robust fraction is the
stable log-fraction of the human family's range."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest

from exotune.analysis import analyze_batch
from exotune.config import batch_config, load_design
from exotune.optimization.evaluate import column, evaluate, robust_fraction
from exotune.optimization.peak import amplification_peak
from exotune.optimization.spec import load_optimize_spec

BASE = copy.deepcopy(load_design(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml").raw)
BASE["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0},
                  {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]
X = np.array([[3.0, 0.7], [8.0, 0.5], [40.0, 0.35]])


def _spec(**constraints):
    return load_optimize_spec({"base": copy.deepcopy(BASE), "objective": "amplification", "budget": 50,
                               "free": {"design.amplification": [1.5, 60.0], "design.zeta_hat": [0.3, 1.2]},
                               "constraints": {"latency_margin_s": 0.0, **constraints}})


@pytest.fixture(scope="module")
def evaluated():
    spec = _spec(max_phase_excess_deg=20.0, amplification_bandwidth_hz=2.0, amplification_peak_db=6.0)
    ev = evaluate(spec, X)
    ref = analyze_batch(batch_config(spec.cfg, {"design.amplification": X[:, 0], "design.zeta_hat": X[:, 1]}))
    return spec, ev, ref


@pytest.mark.parametrize("name", ["passivity_max_phase_excess_deg", "amplification_bandwidth_hz", "amplification_dc",
                                  "free_stable", "locked_stable"])
def test_columns_equal_the_batch_analysis(evaluated, name):
    _, ev, ref = evaluated
    np.testing.assert_allclose(np.asarray(column(ev, name), float), np.asarray(ref.column(name), float),
                               rtol=1e-9, equal_nan=True)


def test_the_peak_column_is_the_peak_of_each_design(evaluated):
    spec, ev, _ = evaluated
    db, hz = amplification_peak(batch_config(spec.cfg, {"design.amplification": X[:, 0],
                                                        "design.zeta_hat": X[:, 1]}))
    np.testing.assert_allclose(column(ev, "amplification_peak_db"), db, rtol=1e-9)
    np.testing.assert_allclose(column(ev, "amplification_peak_hz"), hz, rtol=1e-9)


def test_feasibility_follows_the_constraints(evaluated):
    spec, ev, ref = evaluated
    ok = (ref.free.stable & ref.locked.stable & ref.humans[0].robust & ref.humans[1].robust
          & (ref.passivity.max_phase_excess_deg <= 20.0) & (ref.amplification.bandwidth_hz >= 2.0)
          & (column(ev, "amplification_peak_db") <= 6.0))
    np.testing.assert_array_equal(ev["feasible"], ok)
    np.testing.assert_array_equal(ev["feasible"], ev["violation"] == 0)
    assert np.all(ev["violation"] >= 0)
    np.testing.assert_array_equal(ev["broken"]["max_phase_excess_deg"], ref.passivity.max_phase_excess_deg > 20.0)
    np.testing.assert_allclose(ev["objective"], X[:, 0], rtol=1e-12)  # objective: α


def test_robust_fraction_is_the_stable_log_fraction(evaluated):
    spec, ev, ref = evaluated
    frac = robust_fraction(spec.cfg, ref)
    np.testing.assert_array_equal(frac, ev["robust_fraction"])
    for i in range(len(X)):
        exp = 1.0
        for fam, h in zip(spec.cfg.humans, ref.humans):
            if h.robust[i]:
                continue
            part = sum(math.log(b) - math.log(a) for a, b in h.stable_intervals[i]) / math.log(fam.hi / fam.lo)
            exp = min(exp, part)
        assert frac[i] == pytest.approx(exp, rel=1e-6, abs=1e-8)
        assert 0.0 <= frac[i] <= 1.0 and (frac[i] == 1.0) == all(h.robust[i] for h in ref.humans)


def test_a_tighter_bound_never_adds_feasible_designs(evaluated):
    _, ev, _ = evaluated
    tight = evaluate(_spec(max_phase_excess_deg=1.0, amplification_bandwidth_hz=2.0, amplification_peak_db=6.0), X)
    assert not np.any(tight["feasible"] & ~ev["feasible"])
    assert np.all(tight["violation"] >= ev["violation"] - 1e-12)
