"""exotune.text.simulate: the text of ``exotune simulate`` on a small hand-made report: each
quantity with its unit, words instead of null, the scenario's own sections."""

from exotune.text.simulate import format_simulation


def _rep(**kw):
    rep = {"scenario": "light-mass", "description": "a light mass released", "sample_rate_hz": 1000.0,
           "delay_samples": 1.0,
           "summary": {"start": "bumpless", "verdict": "decaying",
                       "envelope_growth_rate": {"value": -1.25, "unit": "1/s", "tolerance": 0.05},
                       "peak_motor_torque": {"value": 12.5, "unit": "N·m", "signal": "tau_m"},
                       "cuff_oscillation_start_rad": {"value": 0.01, "unit": "rad"},
                       "loop_spectral_radius": {"value": 0.998, "unit": "1", "growth_rate_per_s": -2.0},
                       "diverged": False}}
    rep.update(kw)
    return rep


def test_summary_lines():
    assert format_simulation(_rep()).splitlines() == [
        "exotune simulate — light-mass: a light mass released",
        "  sample rate 1000 Hz, delay 1 sample, start bumpless",
        "  verdict: decaying",
        "  envelope growth rate: -1.25 1/s; tolerance 0.05 1/s",
        "  peak motor torque: 12.5 N·m; measured on tau_m",
        "  cuff oscillation start: 0.01 rad",
        "  loop spectral radius: 0.998 –; growth rate -2 1/s",
        "  diverged: False",
    ]


def test_a_growing_run_says_why_instead_of_null():
    rep = _rep()
    rep["summary"] = {"start": "bumpless", "verdict": "growing", "peak_motor_torque": {"value": None, "unit": "N·m"},
                      "metrics_null_reason": "the run is growing"}
    lines = format_simulation(rep).splitlines()
    assert "  peak motor torque: not measured (see below)" in lines
    assert lines[-1] == "  why these metrics were not measured: the run is growing"
    assert "null" not in "\n".join(lines)


def test_scenario_sections():
    rep = _rep(windup_recovery={"release_at": {"value": 1.0, "unit": "s"},
                                "with_clamp": {"settle_time_s": {"value": 0.12, "unit": "s"}},
                                "without_clamp": {"settle_time_s": {"value": 0.5, "unit": "s"}}},
               limit_cycle={"present": True, "frequency_hz": {"value": 7.5, "unit": "Hz"},
                            "without_backlash": {"verdict": "decaying", "envelope_growth_rate": {"value": -0.51234}}},
               friction_estimate={"rms_error": {"value": 0.1, "unit": "N·m"}},
               friction_sensitivity={"joint_rms": {"value": 0.0321, "unit": "rad"}},
               summary_without_dob={"verdict": "marginal"})
    text = format_simulation(rep)
    for line in ["  windup recovery after the release at 1 s:", "    with clamp:", "      settle time: 0.12 s",
                 "    without clamp:", "      settle time: 0.5 s", "  limit cycle: present", "    frequency: 7.5 Hz",
                 "    the same run without backlash: decaying (envelope growth -0.5123 1/s)",
                 "  the DOB's friction estimate:", "    rms error: 0.1 N·m", "  friction sensitivity joint rms: 0.0321 rad",
                 "  without the DOB:", "    verdict: marginal"]:
        assert line in text.splitlines(), line
    undefined = format_simulation(_rep(limit_cycle={"present": None}))
    assert "  limit cycle: undefined (growing run)" in undefined.splitlines()


def test_the_verdict_says_why_and_the_dominant_oscillation_has_its_units():
    """h8 item 3: the verdict's reason (what decided it) follows the verdict; the loop's dominant
    oscillation prints in Hz and s ("none" for a loop without one); the basis is the JSON's alone."""
    rep = _rep()
    sm = rep["summary"]
    sm.update(verdict="inconclusive", verdict_basis="none", verdict_reason="the run (0.05 s, 50 samples) is short")
    sm["loop_spectral_radius"].update(dominant_oscillation_hz=9.86, dominant_oscillation_period_s=0.101)
    lines = format_simulation(rep).splitlines()
    assert lines[2:4] == ["  verdict: inconclusive", "  why: the run (0.05 s, 50 samples) is short"]
    assert ("  loop spectral radius: 0.998 –; growth rate -2 1/s; dominant oscillation 9.86 Hz; "
            "dominant oscillation period 0.101 s") in lines
    assert not any("basis" in ln for ln in lines)
    sm["loop_spectral_radius"].update(dominant_oscillation_hz=None, dominant_oscillation_period_s=None)
    assert ("  loop spectral radius: 0.998 –; growth rate -2 1/s; dominant oscillation: none; "
            "dominant oscillation period: none") in format_simulation(rep).splitlines()
    undefined = format_simulation(_rep(limit_cycle={"present": None}, summary={**sm, "verdict": "inconclusive"}))
    assert "  limit cycle: undefined (inconclusive run)" in undefined.splitlines()
