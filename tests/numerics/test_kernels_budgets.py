"""Per-task work budgets of the adaptive kernels (exotune.numerics.kernels.MAX_TASK_EVALS /
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

from exotune.numerics import kernels as _fastphase
from exotune.analysis import analyze_batch
from exotune.analysis.charfun import char_terms
from exotune.config import batch_config, design_from_mapping, load_design
from exotune.model.controller import build_controller
from exotune.numerics.quasipoly import adaptive_leaves, leaves_pair, log_grid, omega_max

from unchecked import unchecked

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"


def _pathological():
    """A 1e-12 kg·m² motor inertia: far outside the accepted range, so built without validation."""
    return unchecked(load_design(PAPER), plant__motor_inertia=1e-12)


def test_pathological_design_terminates_inconclusive():
    cols = analyze_batch(_pathological()).to_columns()
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
    alone = analyze_batch(batch_config(base, {"design.amplification": np.array([4.0, 8.0])})).to_columns()
    mixed = analyze_batch(unchecked(batch_config(base, {"design.amplification": np.array([4.0, 8.0, 8.0])}),
                                    plant__motor_inertia=[0.44, 0.44, 1e-12])).to_columns()
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


def _raw(**changes) -> dict:
    """The paper design mapping with ``section__key=value`` changes."""
    raw = yaml.safe_load(PAPER.read_text())
    for path, v in changes.items():
        sec, key = path.split("__")
        raw[sec][key] = v
    return raw


def _cli_refused(tmp_path, field, **changes):
    """``exotune analyze`` (a real process) of the paper design with ``section__key=value`` changes
    beyond the accepted ranges: refused at validation with the field and its range — exit 2, one
    line, no traceback, no numpy warning (these designs used to reach the kernels)."""
    f = tmp_path / "d.yaml"
    f.write_text(yaml.safe_dump(_raw(**changes)))
    r = subprocess.run([sys.executable, "-m", "exotune", "analyze", str(f)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith(f"exotune: error: {field}") and "accepted range" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and "Warning" not in r.stderr, r.stderr
    assert r.stdout == ""


def test_cli_analyze_of_a_pathological_design_is_refused(tmp_path):
    _cli_refused(tmp_path, "plant.motor_inertia", plant__motor_inertia=1e-12)


def test_pathological_design_report_ends_with_a_warning():
    """The engine itself (no validation) still ends with the budget warning and no robust verdict."""
    from exotune.analysis import analyze_design
    from exotune.text.analysis import format_report

    out = format_report(analyze_design(_pathological()).to_dict())
    assert "budget" in out and "robust yes" not in out


def test_optimizer_treats_a_budget_exhausted_design_as_infeasible():
    """A design whose analysis spent its budget (NaN passivity metric, inconclusive verdicts) is
    infeasible for ``exotune optimize``, while the same spec's normal design is feasible."""
    from exotune.optimization import load_optimize_spec
    from exotune.optimization.evaluate import evaluate

    import exotune.analysis as analysis

    raw = yaml.safe_load(PAPER.read_text())
    raw["humans"] = [{"kind": "mass", "inertia": [0.02, 1.0], "damping": 0.0}]
    spec = load_optimize_spec({"base": raw, "objective": "amplification",
                               "free": {"design.amplification": [1.5, 40.0], "plant.motor_inertia": [1e-9, 1.0]},
                               "constraints": {"max_phase_excess_deg": 20.0, "latency_margin_s": 0.0}, "budget": 50})
    # 1e-12 kg·m² is beyond the accepted range: the analysed batch gets it without validation
    real = analysis.analyze_batch

    def patched(cfg, *a, **k):
        mi = np.array(cfg.plant.motor_inertia, dtype=float, copy=True)
        return real(unchecked(cfg, plant__motor_inertia=np.where(mi == 1e-9, 1e-12, mi)), *a, **k)

    mp = __import__("pytest").MonkeyPatch()
    mp.setattr(analysis, "analyze_batch", patched)
    try:
        ev = evaluate(spec, np.array([[4.0, 0.44], [4.0, 1e-9]]))
    finally:
        mp.undo()
    assert ev["feasible"][0] and not ev["feasible"][1]
    assert np.isnan(ev["analysis"].passivity.max_phase_excess_deg[1])
    assert ev["broken"]["max_phase_excess_deg"][1]


# --- found by fuzzing in session 6 -------------------------------------------------------------
def _with(**changes):
    return design_from_mapping(_raw(**changes))


def _delay_tasks(n: int, T: float = 1e4):
    """n copies of Δ = (s + 1)(s + 2) + 1.9 e^{−sT}: stable, but the phase of the delay term winds
    ~ω_max·T times, so each count needs tens of thousands of evaluations."""
    from exotune.numerics.quasipoly import ARG_STEP, DER_STEP, MAX_LEVELS

    P0 = np.repeat([[2.0, 3.0, 1.0]], n, 0)
    P1 = np.repeat([[1.9, 0.0, 0.0]], n, 0)
    return (P0, P1, np.full(n, T), P0, P1, np.zeros(n, bool), ARG_STEP, DER_STEP, MAX_LEVELS)


def test_group_budget_bounds_the_counts_of_one_group():
    """Counts queued as one group (a family's sub-interval counts of one design) share
    MAX_GROUP_EVALS: alone every count resolves; in one group the counts after the budget are
    unresolved (a prefix resolves, the rest does not), and a new group gets a fresh budget."""
    n = 40
    N, _, ok = _fastphase.count_tasks(*_delay_tasks(n))
    assert ok.all() and (N == 0).all()
    N1, _, ok1 = _fastphase.count_tasks(*_delay_tasks(n), group=np.zeros(n, np.int64))
    k = int(ok1.sum())
    assert 0 < k < n
    assert ok1[:k].all() and not ok1[k:].any()
    np.testing.assert_array_equal(N1[:k], N[:k])
    two = np.r_[np.zeros(n // 2, np.int64), np.ones(n // 2, np.int64)]
    _, _, ok2 = _fastphase.count_tasks(*_delay_tasks(n), group=two)
    assert ok2[n // 2]  # the second group starts with a full budget


def test_family_with_thousands_of_critical_values_is_inconclusive():
    """A degenerate design (α = 1, 1e-9 kg·m² felt inertia, 1e9 N·m/rad cuff, 0.2 s delay) has
    ~10⁴ critical inertias: it used to queue 10⁴ budget-spending counts (10 minutes). Past
    MAX_FAMILY_PIECES it is inconclusive at once, and never robust."""
    from exotune.analysis.intervals import MAX_FAMILY_PIECES

    cfg = unchecked(load_design(PAPER), design__amplification=1.0, design__felt_inertia=1e-9,
                    design__felt_damping=1e-12, plant__cuff_stiffness=1e9, implementation__delay_s=0.2)
    cols = analyze_batch(cfg).to_columns()
    assert len(cols["human0_mass_critical"][0]) > MAX_FAMILY_PIECES
    assert not cols["human0_mass_conclusive"][0]
    assert not cols["human0_mass_robust"][0]
    assert cols["human0_mass_stable_intervals"][0] == []


def test_zero_on_the_axis_in_a_refinement_does_not_fail_the_batch():
    """A 1e-12 kg·m² motor inertia with a 1e6 N·m·s/rad motor damping made a value of Δ00 exactly 0
    inside the passivity peak search: numba's complex division raised ZeroDivisionError and the
    whole sweep chunk failed. Now the design is analysed (inconclusive, not stable) next to a
    normal one that keeps its exact results."""
    base = load_design(PAPER)
    alone = analyze_batch(base).to_columns()
    mixed = analyze_batch(unchecked(batch_config(base, {"plant.motor_damping": np.array([17.9, 1e6]),
                                                        "implementation.delay_s": np.array([0.001, 0.0])}),
                                    plant__motor_inertia=[0.44, 1e-12])).to_columns()
    assert mixed["free_stable"][0] == alone["free_stable"][0]
    assert mixed["passivity_max_phase_excess_deg"][0] == alone["passivity_max_phase_excess_deg"][0]
    assert not mixed["free_stable"][1]
    assert not mixed["human0_mass_robust"][1]


def test_cli_analyze_of_a_zero_division_design_is_refused(tmp_path):
    _cli_refused(tmp_path, "plant.motor_inertia", plant__motor_inertia=1e-12, plant__motor_damping=1e6,
                 implementation__delay_s=0.0)


def test_design_whose_gains_overflow_is_refused():
    """A felt inertia of 1e-310 kg·m² (a subnormal float) makes B1 = J_m B̂_m/Ĵ_m − B_m infinite."""
    from exotune.errors import ConfigError

    import pytest

    with pytest.raises(ConfigError) as e:
        _with(design__felt_inertia=1e-310)  # now refused by its range, before any gain is computed
    assert e.value.field == "design.felt_inertia" and "accepted range" in e.value.reason


def test_cli_analyze_of_an_overflowing_design_is_refused(tmp_path):
    """ζ = 1e300 (finite gains, overflowing coefficients) is refused by its range."""
    _cli_refused(tmp_path, "design.zeta", design__zeta=1e300)


def test_overflowing_design_is_inconclusive_without_warnings():
    """The engine itself, given ζ = 1e300 without validation: not stable, inconclusive, no warning."""
    import warnings

    from exotune.analysis import analyze_design
    from exotune.text.analysis import format_report

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        out = format_report(analyze_design(unchecked(load_design(PAPER), design__zeta=1e300)).to_dict())
    assert "Free exoskeleton (cuff free) stable: NO" in out and "inconclusive" in out


def test_the_numpy_group_budget_bounds_the_work_in_flight_and_agrees_with_the_compiled_one(monkeypatch):
    """The numpy counts of one group used to run every task with its own 200 000-evaluation budget
    at once and apply the group's budget afterwards: one extreme design's family of ~1 000
    sub-interval counts took 10–16 GB and minutes. Now every task first runs within an equal share
    of the group's budget, and only those that needed more run again, alone, with what the queue
    order leaves them: no pass has more than the group budget in flight, and the counts (a resolved
    prefix, the same N) equal the compiled kernel's."""
    from exotune.numerics import quasipoly
    from exotune.numerics.budgets import MAX_GROUP_EVALS
    from exotune.numerics.engine import numpy_engine
    from exotune.numerics.quasipoly import QP, count_rhp

    n = 40
    P0, P1, T = _delay_tasks(n)[:3]
    group = np.r_[np.zeros(n - 4, np.int64), np.ones(4, np.int64)]
    Nc, _, okc = _fastphase.count_tasks(*_delay_tasks(n), group=group)
    budgets = []
    real = quasipoly.adaptive_leaves

    def spy(evalfn, ntask, grid, valid=None, **kw):
        me = kw.get("max_evals")
        if me is not None:
            v = np.ones(ntask, bool) if valid is None else valid
            budgets.append(float(np.sum(np.broadcast_to(me, (ntask,))[v])))
        return real(evalfn, ntask, grid, valid, **kw)

    monkeypatch.setattr(quasipoly, "adaptive_leaves", spy)
    with numpy_engine():
        N, ok = count_rhp(QP(P0, P1, T), group=group)
    np.testing.assert_array_equal(ok, okc)
    np.testing.assert_array_equal(N[ok], Nc[ok])
    assert 0 < ok[: n - 4].sum() < n - 4 and ok[n - 4:].all()
    assert budgets and max(budgets) <= 2 * MAX_GROUP_EVALS  # two groups in the first pass, then one task at a time
