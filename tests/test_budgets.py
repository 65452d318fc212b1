"""Per-task work budgets of the adaptive kernels (exotune._fastphase.MAX_TASK_EVALS /
MAX_TASK_LEAVES): a pathological design terminates, its verdicts are inconclusive (never "stable")
and the passivity metrics (which need full frequency coverage) are NaN. Found by fuzzing: a 1e-12 kg·m² motor
inertia with a 1 ms delay made ``exotune analyze`` run for over half an hour (the phase of e^{-jωT}
winds ~ω_max·T times up to a frequency bound of ~1e14 rad/s)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

from exotune import _fastphase
from exotune.analysis import analyze_batch, char_terms
from exotune.config import batch_config, design_from_mapping, load_design
from exotune.controller import build_controller
from exotune.quasipoly import QP, adaptive_leaves, leaves_pair, log_grid, omega_max

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"


def _pathological():
    raw = yaml.safe_load(PAPER.read_text())
    raw["plant"]["motor_inertia"] = 1e-12
    return design_from_mapping(raw)


def test_pathological_design_terminates_inconclusive():
    cols = analyze_batch(_pathological())
    for k in ("human0_mass", "human1_spring", "human2_complex_stiffness"):
        assert not cols[f"{k}_robust"][0]
    assert not cols["passivity_conclusive"][0]
    assert np.isnan(cols["passivity_max_phase_excess_deg"][0])
    # every verdict that is reported stable is conclusive (inconclusive never reads as stable)
    assert not (cols["free_stable"][0] and not cols["free_conclusive"][0])
    assert not (cols["locked_stable"][0] and not cols["locked_conclusive"][0])


def test_pathological_design_in_a_batch_leaves_the_others_exact():
    """The budget is per task: the normal designs of the same batch get the same results as alone."""
    base = load_design(PAPER)
    alone = analyze_batch(batch_config(base, {"design.amplification": np.array([4.0, 8.0])}))
    mixed = analyze_batch(batch_config(base, {"design.amplification": np.array([4.0, 8.0, 8.0]),
                                              "plant.motor_inertia": np.array([0.44, 0.44, 1e-12])}))
    for k, v in alone.items():
        if isinstance(v, np.ndarray):
            np.testing.assert_array_equal(mixed[k][:2], v, err_msg=k)
        else:
            assert mixed[k][:2] == v, k
    assert not mixed["human1_spring_robust"][2]


def test_numpy_reference_leaves_respect_the_same_budget():
    """The numpy reference of the adaptive frequency set stops the same task (unresolved,
    exhausted) with at most the same number of leaves."""
    cfg = _pathological()
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, 1)
    D0, D1 = ct.qp("00"), ct.qp("10")
    wmax = np.maximum(omega_max(D0.p0, D0.p1), omega_max(D1.p0, D1.p1))
    grid = log_grid(wmax, decades=6, per_decade=2)
    lv = leaves_pair(D0, D1, grid, np.ones(1, bool))  # compiled
    assert lv["exhausted"][0] and not lv["resolved"][0]
    assert lv["task"].size <= _fastphase.MAX_TASK_LEAVES

    def evalfn(idx, w):
        return [D0.eval(idx, w), D1.eval(idx, w)]

    ref = adaptive_leaves(evalfn, 1, grid, np.ones(1, bool))
    assert ref["exhausted"][0] and not ref["resolved"][0]
    assert ref["task"].size <= _fastphase.MAX_TASK_LEAVES


def test_cli_analyze_of_a_pathological_design_ends_with_a_warning(tmp_path):
    raw = yaml.safe_load(PAPER.read_text())
    raw["plant"]["motor_inertia"] = 1e-12
    f = tmp_path / "d.yaml"
    f.write_text(yaml.safe_dump(raw))
    out = subprocess.run([sys.executable, "-m", "exotune", "analyze", str(f)], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert "budget" in out.stdout and "robust yes" not in out.stdout


def test_optimizer_treats_a_budget_exhausted_design_as_infeasible():
    """A design whose analysis spent its budget (NaN passivity metric, inconclusive verdicts) is
    infeasible for ``exotune optimize``, while the same spec's normal design is feasible."""
    from exotune.optimize import evaluate, load_optimize_spec

    raw = yaml.safe_load(PAPER.read_text())
    raw["humans"] = [{"kind": "mass", "inertia": [0.02, 1.0], "damping": 0.0}]
    spec = load_optimize_spec({"base": raw, "objective": "amplification",
                               "free": {"design.amplification": [1.5, 40.0], "plant.motor_inertia": [1e-12, 1.0]},
                               "constraints": {"max_phase_excess_deg": 20.0}, "budget": 50})
    ev = evaluate(spec, np.array([[4.0, 0.44], [4.0, 1e-12]]))
    assert ev["feasible"][0] and not ev["feasible"][1]
    assert np.isnan(ev["columns"]["passivity_max_phase_excess_deg"][1])
    assert ev["broken"]["max_phase_excess_deg"][1]
