"""exotune.text.design: the text of ``exotune design`` on a small hand-made report, and the root lines."""

import math

from exotune.text.design import format_design, format_roots


def test_format_roots():
    roots = [{"re": -2.0, "im": 0.0, "natural_frequency_hz": 0.31831, "damping_ratio": 1.0},
             {"re": -3.0, "im": 40.0, "natural_frequency_hz": 6.384, "damping_ratio": 0.0748},
             {"re": -3.0, "im": -40.0, "natural_frequency_hz": 6.384, "damping_ratio": 0.0748},
             {"re": 0.0, "im": 0.0, "natural_frequency_hz": 0.0, "damping_ratio": math.nan}]
    assert format_roots(roots) == ["-2 rad/s (f_n = 0.3183 Hz, ζ = 1)",
                                   "-3 ± 40j rad/s (f_n = 6.384 Hz, ζ = 0.0748)",  # one line per conjugate pair
                                   "0 rad/s (f_n = 0 Hz)"]
    assert format_roots([]) == ["none"]


def _rep(**kw):
    rep = {"exotune_version": "9.9", "source": "paper.yaml", "gain_convention_note": "torque units",
           "gains": {"K1": 0.0, "K2_hat": 7.0}, "units": {"K1": "N·m/rad", "K2_hat": "1 (N·m/N·m)"},
           "shape": {"J_m_hat": 2.0}, "shape_units": {"J_m_hat": "kg·m²"},
           "transfer_functions": {"C5_hat": {"transfer": "1/(Ĵ_m s² + B̂_m s)", "units": "rad/(N·m)",
                                             "description": "the virtual motor",
                                             "poles": [{"re": 0.0, "im": 0.0, "natural_frequency_hz": 0.0,
                                                        "damping_ratio": None},
                                                       {"re": -4.0, "im": 0.0, "natural_frequency_hz": 0.6366,
                                                        "damping_ratio": 1.0}],
                                             "zeros": []}},
           "approximation": {"criterion": "|C5/Ĉ5 − 1| < 10 %", "valid_below_hz": 12.3456, "J_m_hat_over_J_j": 6.8966},
           "warnings": []}
    rep.update(kw)
    return rep


def test_format_design_lines():
    lines = format_design(_rep()).splitlines()
    assert lines[0] == "exotune 9.9 design — paper.yaml"
    assert lines[2] == "Gain convention: torque units."
    assert lines[5].split() == ["K1", "0", "N·m/rad"]
    assert lines[6].split() == ["K2_hat", "7", "–", "(N·m/N·m)"]  # dimensionless shown as "–"
    assert lines[9].split() == ["J_m_hat", "2", "kg·m²"]
    i = lines.index("  C5_hat = 1/(Ĵ_m s² + B̂_m s) [rad/(N·m)]: the virtual motor")
    assert lines[i + 1:i + 4] == ["    poles: 0 rad/s (f_n = 0 Hz)", "           -4 rad/s (f_n = 0.6366 Hz, ζ = 1)",
                                  "    zeros: none"]
    assert "Approximation Ĉ5 ≈ C5: |C5/Ĉ5 − 1| < 10 % for f < 12.35 Hz (Ĵ_m/J_j = 6.897)" in lines
    assert lines[-1] == "Warnings: none"


def test_format_design_with_warnings_and_no_source():
    lines = format_design(_rep(source=None, warnings=["B2_hat < 0"])).splitlines()
    assert lines[0] == "exotune 9.9 design"
    assert lines[-2:] == ["Warnings", "  - B2_hat < 0"]
