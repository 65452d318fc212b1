"""exotune.text.optimize: the text of ``exotune optimize`` on small hand-made results — every
number with its unit (the optimized parameters included), the infeasible report's violations."""

from exotune.text.optimize import format_optimize, ms_text, unit_word


def test_helpers():
    assert ms_text(0.0012345) == "1.2345 ms" and ms_text(None) == "unbounded" and ms_text(float("inf")) == "unbounded"
    assert unit_word("1") == "–" and unit_word("1 (relative)") == "– (relative)" and unit_word("Hz") == "Hz"


def _feasible(**kw):
    r = {"feasible": True, "evaluated": 42,
         "objective": {"name": "felt_compliance", "value": 0.123456789, "unit": "1", "sense": "min"},
         "x": {"design.felt_inertia": 0.25, "implementation.dob.cutoff_hz": 60.0, "design.amplification": 8.0},
         "active_constraints": [], "at_bounds": [{"parameter": "design.felt_inertia", "value": 0.05, "bound": "lower"}],
         "near_binding": ["robust"],
         "latency_margin": {"achieved_s": 0.0025, "required_s": 0.0005, "required_from": "default: half a sample",
                            "achieved_samples": 1.0},
         "metrics": {"dob_phase_margin_deg": {"value": 45.0, "unit": "deg", "frequency_hz": 12.5},
                     "human_stable_intervals": {"human0_mass_stable_intervals": [[0.01, 1.0]],
                                                "human1_spring_stable_intervals": []}},
         "certificate_warning": "no KYP certificate", "pareto": [1, 2, 3]}
    r.update(kw)
    return r


def test_feasible_report_lines():
    assert format_optimize(_feasible()).splitlines() == [
        "optimum (42 designs analysed exactly): felt_compliance = 0.123457 – (minimized)",
        "  design.felt_inertia = 0.25 kg·m²",
        "  implementation.dob.cutoff_hz = 60 Hz",
        "  design.amplification = 8 –",
        "  active constraints (binding at the optimum): none",
        "  at their bounds: design.felt_inertia = 0.05 kg·m² (lower)",
        "  within 1 % of their bound: robust",
        "  latency margin (exact): 2.5 ms = 1 sample; required ≥ 0.5 ms (default: half a sample)",
        "  dob_phase_margin_deg: 45 deg at 12.5 Hz",
        "  human0_mass_stable_intervals: [0.01, 1] kg·m²",
        "  human1_spring_stable_intervals: none",
        "  WARNING: no KYP certificate",
        "  Pareto front (objective vs robust fraction): 3 designs",
    ]


def test_sampled_model_of_record():
    r = _feasible(latency_margin={"achieved_s": 0.002, "required_s": 0.0, "required_from": "spec", "achieved_samples": 2.0,
                                  "model": "sampled-data at 1000 Hz", "continuous_s": 0.0031},
                  sampled_data={"certifiable": False, "rounds": 1, "continuous_constraint_s": 0.0015, "polished": True,
                                "problems": ["locked joint unstable"],
                                "verdicts": {"sample_rate_hz": 1000.0, "environment": [],
                                             "humans": [{"kind": "mass", "parameter": "inertia", "unit": "kg·m²",
                                                         "stable_intervals": [[0.02, 1.0]]}]}})
    lines = format_optimize(r).splitlines()
    assert ("  latency margin (sampled-data at 1000 Hz, the model of record): 2 ms = 2 samples; none required (spec); "
            "continuous-time 3.1 ms (not what the runtime tolerates)") in lines
    assert ("  sampled-data verdicts of record at 1000 Hz: NOT CERTIFIABLE; 1 tightening round of the continuous search "
            "(continuous latency constraint raised to 1.5 ms); objective polished on the sampled-data verdicts") in lines
    assert "    sampled-data mass inertia: stable on [0.02, 1] kg·m²" in lines
    assert "    - locked joint unstable" in lines


def test_infeasible_report():
    r = {"feasible": False, "evaluated": 60, "broken": ["robust", "dob_delay_margin_s", "free_stable"],
         "x": {"design.amplification": 30.0},
         "violations": [{"constraint": "robust", "family": "human0_mass", "parameter": "inertia", "range": [1e-4, 1.0],
                         "unit": "kg·m²", "unstable": [[1e-4, 0.004]]},
                        {"constraint": "dob_delay_margin_s", "value": 0.0012, "unit": "s", "op": ">=", "bound": 1.0},
                        {"constraint": "free_stable"}],
         "at_bounds": [{"parameter": "design.amplification", "value": 30.0, "bound": "lower"}]}
    assert format_optimize(r).splitlines() == [
        "NO FEASIBLE DESIGN found in the bounds after 60 exact analyses; the best one breaks: robust, "
        "dob_delay_margin_s, free_stable",
        "  design.amplification = 30 –",
        "  robust: human0_mass not stable over inertia ∈ [0.0001, 1] kg·m², unstable for [0.0001, 0.004] kg·m²",
        "  dob_delay_margin_s: 0.0012 s, needed >= 1 s",
        "  free_stable: false, needed true",
        "  at their bounds: design.amplification = 30 – (lower)",
    ]
