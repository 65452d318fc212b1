"""exotune optimize (SPEC §7): the optimum is checked by an independent path — the single-design
analysis (exotune.analysis.core.analyze_design) at the optimum and just past it, and a dense batch scan
of the objective parameter — plus determinism, the Pareto property and the CLI contract."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from exotune.analysis.core import analyze_batch, analyze_design
from exotune.cli import cli
from exotune.config.design import batch_config, design_from_mapping, load_design
from exotune.optimize import format_optimize, load_optimize_spec, optimize, optimized_design_mapping

ROOT = Path(__file__).resolve().parents[1]


def _base(mass_lo=0.01, delay=0.002):
    raw = copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)
    raw["implementation"]["delay_s"] = delay
    raw["humans"] = [{"kind": "mass", "inertia": [mass_lo, 1.0], "damping": 0.0},
                     {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]
    return raw


def _spec(**kw):
    s = {"base": _base(), "objective": "amplification",
         "free": {"design.amplification": [1.5, 60.0], "design.zeta_hat": [0.3, 1.2]},
         "constraints": {"max_phase_excess_deg": 20.0, "amplification_bandwidth_hz": 2.0}, "budget": 300}
    s.update(kw)
    return s


@pytest.fixture(scope="module")
def result():
    spec = load_optimize_spec(_spec())
    return spec, optimize(spec, pareto=True)


def test_optimum_is_feasible_by_the_single_design_analysis(result):
    spec, r = result
    assert r["feasible"]
    cfg = design_from_mapping(optimized_design_mapping(spec, r))
    rep = analyze_design(cfg)
    assert rep["free_stable"] and rep["locked_stable"]
    assert all(h["robust"] for h in rep["humans"])
    assert rep["passivity"]["max_phase_excess_deg"] <= 20.0 + 1e-9
    assert rep["amplification"]["bandwidth_hz"] >= 2.0 - 1e-9
    assert r["objective"]["value"] == pytest.approx(float(cfg.design.amplification))


def test_active_constraint_is_broken_just_past_the_optimum(result):
    spec, r = result
    assert r["active_constraints"], r
    raw = optimized_design_mapping(spec, r)
    raw["design"]["amplification"] *= 1.002
    rep = analyze_design(design_from_mapping(raw))
    broken = {
        "robust": not all(h["robust"] for h in rep["humans"]),
        "max_phase_excess_deg": rep["passivity"]["max_phase_excess_deg"] > 20.0,
        "amplification_bandwidth_hz": rep["amplification"]["bandwidth_hz"] < 2.0,
    }
    assert any(broken[a] for a in r["active_constraints"] if a in broken), (r["active_constraints"], broken)


def test_one_dimensional_optimum_matches_a_dense_scan():
    """Free α only: the optimizer's α equals the last feasible α of a dense batch scan (within its
    spacing), where feasibility is recomputed from the raw sweep columns."""
    spec = load_optimize_spec(_spec(free={"design.amplification": [1.5, 60.0]}))
    r = optimize(spec)
    a = np.geomspace(1.5, 60.0, 400)
    cols = analyze_batch(batch_config(spec.cfg, {"design.amplification": a}))
    ok = (cols["free_stable"] & cols["locked_stable"] & cols["human0_mass_robust"] & cols["human1_spring_robust"]
          & (cols["passivity_max_phase_excess_deg"] <= 20.0) & (cols["amplification_bandwidth_hz"] >= 2.0))
    assert ok[0] and not ok.all()
    first_bad = int(np.argmin(ok))
    assert a[first_bad - 1] <= r["x"]["design.amplification"] * (1 + 1e-9)
    assert r["x"]["design.amplification"] <= a[first_bad] * (1 + 1e-9)


def test_deterministic_for_a_seed(result):
    spec, r = result
    r2 = optimize(load_optimize_spec(_spec()))
    assert r2["x"] == r["x"] and r2["objective"] == r["objective"]


def test_pareto_front_is_non_dominated(result):
    _, r = result
    front = r["pareto"]
    assert front
    obj = [p["objective"] for p in front]
    rf = [p["robust_fraction"] for p in front]
    assert obj == sorted(obj, reverse=True)
    assert all(b > a for a, b in zip(rf, rf[1:]))
    assert rf[-1] == 1.0 and obj[-1] >= r["objective"]["value"] - 1e-9


def test_cli_writes_a_loadable_design_and_rejects_bad_specs(tmp_path):
    base = tmp_path / "base.yaml"
    base.write_text(yaml.safe_dump(_base()))
    spec = _spec(base="base.yaml")
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(spec))
    runner = CliRunner()
    out = tmp_path / "best.yaml"
    res = runner.invoke(cli, ["optimize", str(tmp_path / "s.yaml"), "-o", str(out), "--seed", "3"])
    assert res.exit_code == 0, res.output
    cfg = load_design(out)
    assert 1.5 <= float(cfg.design.amplification) <= 60.0
    bad = {
        "objective: design.zeta is not an objective": dict(spec, objective="zeta"),
        "free.design.amplification": dict(spec, free={"design.amplification": [60.0, 2.0]}),
        "constraints.foo": dict(spec, constraints={"foo": 1.0}),
        "free.humans": dict(spec, free={"humans": [1, 2]}),
        "objective": dict(spec, free={"design.zeta_hat": [0.3, 1.2]}),  # α objective but α not free
        "budget": dict(spec, budget=3),
        "objective:list": dict(spec, objective=["amplification"]),  # unhashable: found by fuzzing
        "objective:mapping": dict(spec, objective={"amplification": 1}),
        "constraints:number": dict(spec, constraints=0),
        "constraints:list": dict(spec, constraints=[]),
        "constraints.max_phase_excess_deg": dict(spec, constraints={"max_phase_excess_deg": -1.0}),
    }
    for field, s in bad.items():
        p = tmp_path / "bad.yaml"
        p.write_text(yaml.safe_dump(s))
        o = tmp_path / "never.yaml"
        res = runner.invoke(cli, ["optimize", str(p), "-o", str(o)])
        assert res.exit_code == 2, (field, res.output)
        assert field.split(":")[0].split(" ")[0] in res.output
        assert "Traceback" not in res.output and not o.exists()


def test_infeasible_problem_exits_1_and_writes_nothing(tmp_path):
    s = _spec(base=_base(mass_lo=1e-4), free={"design.amplification": [30.0, 60.0]},
              constraints={"dob_delay_margin_s": 1.0})  # a 1 s DOB delay margin is impossible
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(s))
    o = tmp_path / "best.yaml"
    res = CliRunner().invoke(cli, ["optimize", str(p), "-o", str(o)])
    assert res.exit_code == 1, res.output
    assert "NO FEASIBLE DESIGN" in res.output and not o.exists()


def test_optimum_is_checked_in_the_sampled_data_loop_when_a_rate_is_given():
    """At 1 kHz the zero-order hold costs phase: masses just above 0.005 kg·m², robust in the
    continuous search, are unstable in the sampled-data loop (its boundary is ≈ 0.0055 for the
    §9 design). The result must carry the sampled-data warning of the single-design analysis."""
    raw = _base(mass_lo=0.005, delay=0.001)
    raw["implementation"].update(sample_rate_hz=1000.0)
    spec = load_optimize_spec(_spec(base=raw, free={"design.amplification": [1.5, 60.0]},
                                    constraints={}, budget=100))
    r = optimize(spec)
    assert r["feasible"]
    rep = analyze_design(design_from_mapping(optimized_design_mapping(spec, r)))
    expected = [w for w in rep["warnings"] if "sampled-data" in w]
    assert expected and r["sampled_data_warnings"] == expected
    assert "WARNING" in format_optimize(r)


def test_relaxing_a_constraint_never_lowers_the_optimum():
    """Allowing lighter humans (a wider mass range) can only lower the largest robust α; a looser
    bandwidth bound can only raise it (1-D problems: the boundary is bisected)."""
    def best(mass_lo, bw):
        s = _spec(base=_base(mass_lo=mass_lo), free={"design.amplification": [1.5, 60.0]},
                  constraints={"amplification_bandwidth_hz": bw}, budget=100)
        return optimize(load_optimize_spec(s))["x"]["design.amplification"]

    a_wide, a_narrow = best(0.005, 2.0), best(0.02, 2.0)
    assert a_wide <= a_narrow * (1 + 1e-6)
    assert best(0.02, 1.0) >= a_narrow * (1 - 1e-6)


def test_felt_compliance_objective_minimizes_felt_inertia():
    s = _spec(objective="felt_compliance", free={"design.felt_inertia": [0.05, 1.0]},
              constraints={"amplification_bandwidth_hz": 2.0}, budget=100)
    r = optimize(load_optimize_spec(s))
    assert r["feasible"] and r["objective"]["sense"] == "min"
    assert r["x"]["design.felt_inertia"] == pytest.approx(r["objective"]["value"])
    # just below the optimum the design breaks a constraint (or it sits on the bound)
    if r["x"]["design.felt_inertia"] > 0.05 * (1 + 1e-6):
        raw = optimized_design_mapping(load_optimize_spec(s), r)
        raw["design"]["felt_inertia"] *= 0.995
        rep = analyze_design(design_from_mapping(raw))
        assert (not all(h["robust"] for h in rep["humans"])) or rep["amplification"]["bandwidth_hz"] < 2.0 \
            or not rep["free_stable"] or not rep["locked_stable"]


def test_nominal_passive_constraint_meets_its_closed_form_and_is_certified():
    """Only nominal passivity constrains the felt inertia: fd ≤ 2ζ̂√(K_c·fi) (kyp.nominal_shortage),
    so the lightest feasible felt inertia is (fd/2ζ̂)²/K_c; the optimum carries the KYP
    certificates (cvxpy) and the nominal one confirms it."""
    base = _base()
    base["design"]["felt_damping"] = 1.0
    base["design"]["zeta_hat"] = 0.7
    s = _spec(base=base, objective="felt_inertia", free={"design.felt_inertia": [0.0005, 0.05]},
              constraints={"robust": False, "free_stable": False, "locked_stable": False, "nominal_passive": True},
              budget=100)
    r = optimize(load_optimize_spec(s))
    expect = (1.0 / (2 * 0.7)) ** 2 / 300.0
    assert r["active_constraints"] == ["nominal_passive"]
    assert r["x"]["design.felt_inertia"] == pytest.approx(expect, rel=2e-3)
    assert r["x"]["design.felt_inertia"] >= expect * (1 - 1e-9)  # feasible side
    certs = r["passivity_certificates"]
    assert certs["nominal"]["passive"] is True and "certificate_warning" not in r
    assert "KYP certificate, nominal" in format_optimize(r)
    # without the constraint the optimum goes to the bound, where the nominal C7 is not passive
    s["constraints"]["nominal_passive"] = False
    r2 = optimize(load_optimize_spec(s))
    assert r2["x"]["design.felt_inertia"] == pytest.approx(0.0005)
    assert r2["passivity_certificates"]["nominal"]["passive"] is False
