"""exotune.text.sea: the text of ``exotune sea`` on a small hand-made report: every number with its unit."""

from exotune.text.sea import format_sea

U = {"K1": "N·m/rad", "B1": "N·m·s/rad", "K2": "1 (N·m/N·m)", "B2": "s"}
UD = {"K1": "N·m/rad", "B1": "N·m·s/rad", "K2": "N·m/rad", "B2": "N·m·s/rad"}


def _rep(**kw):
    rep = {"exotune_version": "9.9.9", "source": "sea.yaml", "input_gain_units": "torque",
           "gains_torque": {"K1": 100.0, "B1": 2.0, "K2": 0.5, "B2": 0.001},
           "gains_torque_units": U, "gains_deflection": {"K1": 100.0, "B1": 2.0, "K2": 590.0, "B2": 1.18},
           "gains_deflection_units": UD, "shape": {"K1_tilde": 227.0, "B1_tilde": 45.2},
           "shape_units": {"K1_tilde": "1/s²", "B1_tilde": "1/s"}, "low_frequency_stiffness": 0.0,
           "resonance_hz": 12.3456, "resonance_peak_compliance": 0.00123456,
           "c5_poles": [{"re": -3.0, "im": 0.0, "natural_frequency_hz": 0.477, "damping_ratio": 1.0}],
           "c5_stable": True, "passivity": {"passive": False, "conditions": {"K1 >= 0": True, "B2 >= 0": False}},
           "max_phase_deg": 12.5, "max_phase_hz": 200.0, "min_phase_deg": -90.0, "min_phase_hz": 1.0,
           "notes": ["a note"]}
    rep.update(kw)
    return rep


def test_format_sea_exact_lines():
    lines = format_sea(_rep()).splitlines()
    assert lines[0] == "exotune 9.9.9 sea — sea.yaml"
    assert lines[3] == "Gains (input given in torque units)"
    assert lines[4].split() == ["K1", "100", "N·m/rad", "=", "100", "N·m/rad"]
    assert lines[6].split() == ["K2", "0.5", "–", "(N·m/N·m)", "=", "590", "N·m/rad"]  # dimensionless as "–"
    assert lines[7].split() == ["B2", "0.001", "s", "=", "1.18", "N·m·s/rad"]
    assert lines[10].split() == ["K1_tilde", "227", "1/s²"]
    assert ("Low-frequency stiffness 1/C4(0) = K_s K̃1/K̃2: 0 N·m/rad (K1 = 0: no position feedback, zero static "
            "stiffness)") in lines
    assert "Resonance of C5 = θ_j/τ_j (paper eq. (10)): 12.346 Hz, peak |C5| = 0.001235 rad/(N·m)" in lines
    assert "C5 poles (stable):" in lines and "  -3 rad/s (f_n = 0.477 Hz, ζ = 1)" in lines
    assert "Nominal passivity conditions: NOT passive" in lines
    assert "  [ok] K1 >= 0" in lines and "  [FAIL] B2 >= 0" in lines
    assert ("Phase of C4(jω): max 12.5 deg at 200 Hz, min -90 deg at 1 Hz (passive compliance: phase within "
            "[−180°, 0°])") in lines
    assert lines[-2:] == ["Notes", "  - a note"]


def test_format_sea_variants():
    text = format_sea(_rep(source=None, low_frequency_stiffness=2830.04, resonance_hz=None, notes=[],
                           c5_stable=False, passivity={"passive": True, "conditions": {}}))
    lines = text.splitlines()
    assert lines[0] == "exotune 9.9.9 sea"
    assert "Low-frequency stiffness 1/C4(0) = K_s K̃1/K̃2: 2830.04 N·m/rad" in lines
    assert "Resonance of C5 = θ_j/τ_j (paper eq. (10)): none (no peak of |C5(jω)|)" in lines
    assert "C5 poles (UNSTABLE):" in lines
    assert "Nominal passivity conditions: all hold (passive)" in lines
    assert "Notes" not in lines and not text.endswith("\n")


def test_parentheses_balance_in_every_line():
    for line in format_sea(_rep()).splitlines() + format_sea(_rep(resonance_hz=None)).splitlines():
        assert line.count("(") == line.count(")"), line
