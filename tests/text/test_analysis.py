"""exotune.text.analysis: the text of ``exotune analyze`` on a small hand-made analysis: the
verdicts, each number with its unit, long lists cut, the optional sections."""

from exotune.text.analysis import TEXT_LIST_MAX, format_report


def _rep(**kw):
    r = {"model": "continuous-time analysis", "delay_s": 0.001, "structure": "default",
         "gains": {"K1": 0.0, "K2_hat": 7.0}, "units": {"K1": "N·m/rad", "K2_hat": "1"},
         "free_stable": True, "free": {"rigid_body_roots": 1}, "locked_stable": False,
         "environment": [{"kind": "locked", "stable": False},
                         {"kind": "spring", "parameter": "stiffness", "range": [10.0, 1000.0], "robust": True,
                          "stable_intervals": [[10.0, 1000.0]]}],
         "humans": [{"kind": "mass", "parameter": "inertia", "range": [0.001, 1.0], "unit": "kg·m²", "robust": False,
                     "stable_intervals": [[0.0123, 1.0]], "critical": [{"value": 0.0123, "frequency_hz": 45.678}],
                     "lowest_stable_value_below_range_top": 0.0123}],
         "passivity": {"max_phase_excess_deg": 12.3456, "nonpassive_band_hz": [[10.0, 20.0]], "kyp": None},
         "dob": {"gain_margin_db": 6.02, "phase_margin_deg": 45.5, "delay_margin_s": 0.0042, "crossover_hz": 30.1,
                 "stable": True},
         "amplification": {"dc": 8.0, "bandwidth_hz": 5.5, "minimum_phase": True}, "J_m_hat_over_J_j": 6.8966,
         "warnings": ["w1"]}
    r.update(kw)
    return r


def test_report_lines():
    lines = format_report(_rep()).splitlines()
    expected = [
        "exotune analyze — continuous-time analysis",
        "delay T = 1 ms, controller structure 'default'",
        "Free exoskeleton (cuff free) stable: yes (rigid-body roots at s=0 removed: 1)",
        "Output locked stable:               NO",
        "Environment locked: stable NO",
        "Environment spring stiffness in [10, 1000] N·m/rad: robust yes, stable on [10, 1000] N·m/rad",
        "  mass              inertia in [0.001, 1] kg·m²: robust NO",
        "    stable on [0.0123, 1] kg·m²",
        "    boundary at inertia = 0.0123 kg·m² (crossing at 45.68 Hz)",
        "    lightest stable inertia: 0.0123 kg·m²",
        "Passivity of C7: max phase excess 12.35 deg outside [-180°, 0°]; non-passive bands: [10, 20] Hz",
        "DOB loop L_dob = Q e^(-sT)/(1-Q): gain margin 6.02 dB, phase margin 45.5 deg, delay margin 4.2 ms (extra "
        "delay), crossover 30.1 Hz",
        "Amplification C6/C5: DC 8, -3 dB bandwidth 5.5 Hz, minimum phase yes",
        "J_m_hat / J_j = 6.897",
        "warning: w1",
    ]
    for line in expected:
        assert line in lines, line
    assert [ln.split() for ln in lines if ln.startswith("  K")] == [["K1", "=", "0", "[N·m/rad]"],
                                                                  ["K2_hat", "=", "7", "[–]"]]
    assert lines.index(expected[3]) < lines.index(expected[6]) < lines.index(expected[10])


def test_long_interval_lists_are_cut():
    many = [[float(i), i + 0.5] for i in range(TEXT_LIST_MAX + 3)]
    h = {**_rep()["humans"][0], "stable_intervals": many,
         "critical": [{"value": float(i), "frequency_hz": 1.0} for i in range(TEXT_LIST_MAX + 3)]}
    lines = format_report(_rep(humans=[h])).splitlines()
    stable = next(ln for ln in lines if ln.startswith("    stable on"))
    assert stable.endswith(f"kg·m² … ({TEXT_LIST_MAX + 3} intervals in all; --json lists every one)")
    assert stable.count("[") == TEXT_LIST_MAX
    assert sum(ln.startswith("    boundary at") for ln in lines) == TEXT_LIST_MAX
    assert f"    … {TEXT_LIST_MAX + 3} boundaries in all (--json lists every one)" in lines


def test_optional_sections():
    box = {"kind": "msd", "box": {"inertia": [0.1, 0.2], "stiffness": [10.0, 20.0]}, "robust": True,
           "edges": [{"parameter": "inertia", "at": {"stiffness": 10.0}, "range": [0.1, 0.2],
                      "stable_intervals": [[0.1, 0.2]]}]}
    r = _rep(humans=[box], dob=None, warnings=[],
             gain_schedule=[{"joint_angle_rad": 0.5, "ratio": 1.1, "robust": False, "not_robust": ["mass"],
                             "gains": {"K2": -0.5, "B2": 0.001}}],
             cross_check={"pade_orders": [4, 6], "agree": 9, "checked": 10, "unconfirmed": [1],
                          "disagreements": [{"case": "human0 at 0.5", "rhp_root": {"re": 0.25, "im": 12.0}}]})
    lines = format_report(r).splitlines()
    assert ("  msd               box inertia in [0.1, 0.2] kg·m², stiffness in [10, 20] N·m/rad: robust yes (Edge "
            "Theorem, 1 edges)") in lines
    assert "    edge inertia at stiffness = 10 N·m/rad: stable on [0.1, 0.2] kg·m² (the whole edge)" in lines
    assert "DOB: none" in lines
    assert "Gain schedule, joint angle 0.5 rad (ratio 1.1): NOT robust: mass; K2 = -0.5, B2 = 0.001 s" in lines
    assert ("Cross-check (Padé [4, 6] roots + Newton on the exact Δ): 9 of 10 verdicts agree; 1 unstable verdicts not "
            "confirmed by the root search") in lines
    assert "  DISAGREEMENT at human0 at 0.5: exotune says stable, but Δ has a root at 0.25 + 12j rad/s" in lines
    assert not any(ln.startswith("warning:") for ln in lines)


def test_an_inconclusive_family_without_intervals_says_so():
    """No interval listed because the family is inconclusive reads as such, not as 'stable on
    none' (which would claim every member unstable); a conclusive family with none keeps it."""
    h = {**_rep()["humans"][0], "stable_intervals": [], "critical": [], "conclusive": False,
         "lowest_stable_value_below_range_top": None}
    lines = format_report(_rep(humans=[h])).splitlines()
    assert not any(ln.startswith("    stable on") for ln in lines)
    assert any(ln.startswith("    inconclusive: ") and "no interval is claimed stable" in ln for ln in lines)
    lines = format_report(_rep(humans=[{**h, "conclusive": True}])).splitlines()
    assert "    stable on none" in lines
