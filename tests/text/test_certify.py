"""exotune.text.certify: the exact wording of a certify report and of its family/margin lines."""

from exotune.text.certify import family_line, format_certify, margin_line, precision_line

HUMAN = {"kind": "msd", "parameter": "stiffness", "unit": "N·m/rad", "range": [10.0, 500.0], "robust": False,
         "stable_intervals": [[10.0, 320.5]]}
BOX = {**HUMAN, "robust": True, "stable_intervals": [[10.0, 500.0]], "box": {"inertia": [0.05, 0.2]}}
ENV = {"kind": "spring", "parameter": "stiffness", "unit": "N·m/rad", "range": [100.0, 1e4], "skipped": "no rate"}


def test_family_lines():
    assert family_line(HUMAN) == ("  msd stiffness [10, 500] N·m/rad: NOT robust; stable in [10, 320.5] N·m/rad")
    assert family_line(BOX) == ("  msd stiffness [10, 500] N·m/rad × inertia [0.05, 0.2] kg·m²: robust; "
                                "stable in [10, 500] N·m/rad")
    assert family_line(ENV) == "  spring stiffness [100, 10000] N·m/rad: skipped (no rate)"
    assert family_line({**HUMAN, "stable_intervals": []}).endswith("NOT robust; no member is stable")
    nc = {k: v for k, v in HUMAN.items() if k not in ("robust", "stable_intervals")}
    assert family_line({**nc, "not_certifiable": "box too large"}).endswith(": not certifiable (box too large)")


def test_margin_lines():
    lm = {"extra_delay_s": 0.0012, "extra_delay_samples": 1.2, "method": "bisection",
          "critical": {"loop": "human msd", "parameter": "stiffness", "value": 500.0, "unit": "N·m/rad"},
          "predicted_continuous_s": 0.0015, "required_s": 0.001}
    assert margin_line(lm) == ("  latency margin (sampled-data): 1.2 ms (1.2 samples), critical human msd at "
                               "stiffness = 500 N·m/rad; predicted continuous 1.5 ms; required 1 ms")
    none = {"extra_delay_s": None, "extra_delay_samples": None, "method": "scan", "critical": None,
            "predicted_continuous_s": None}
    assert margin_line(none) == ("  latency margin (sampled-data): no instability up to 200 samples of total delay; "
                                 "predicted continuous none; no requirement in the file")
    zero = {**lm, "extra_delay_s": 0.0, "extra_delay_samples": 0.0, "required_s": 0.0,
            "critical": {"loop": "free", "parameter": None}}
    assert margin_line(zero) == ("  latency margin (sampled-data): 0 ms (0 samples), critical free (bisection); "
                                 "predicted continuous 1.5 ms; required none (0)")


PRECISION = {"asked": True, "form": "sos", "total": {"value": 1.5e-6}, "arithmetic": {"value": 1e-6},
             "coefficients": {"value": 5e-7}, "arithmetic_rms_estimate": {"value": 2e-8}, "horizon": {"seconds": 10.0},
             "input_amplitudes": {"theta_m": {"value": 3.0, "unit": "rad"}, "tau_s": {"value": 50.0, "unit": "N·m"}},
             "by_location": [{"where": "G_c section 2", "bound": {"value": 9e-7}}]}


def test_precision_line():
    assert precision_line(PRECISION) == (
        "  certify --precision float32 (the file is float64 and unchanged): float32 (sos realization, analysed "
        "exactly): |float32 - float64 controller| <= 1.5e-06 N·m (arithmetic 1e-06, coefficients 5e-07; typical "
        "2e-08 N·m rms) over 10 s from rest for |inputs| <= theta_m 3 rad, tau_s 50 N·m; largest share G_c "
        "section 2 9e-07 N·m")


def _report(certified):
    return {"schema": "exotune-controller/1", "sample_rate_hz": {"value": 1000.0, "unit": "Hz"}, "delay_s": 0.0015,
            "golden": {"samples": 2000, "max_abs_error": {"value": 3.2e-13, "unit": "N·m"}},
            "sampled": {"free_stable": True, "free_spectral_radius": 0.9987654321, "locked_stable": None,
                        "locked_spectral_radius": 1.0, "humans": [HUMAN], "environment": [ENV]},
            "gain_schedule": [{"joint_angle_rad": 0.5, "ratio": 1.2, "robust": False, "not_robust": ["msd stiffness"]}],
            "method": "exact z-domain", "certified": certified,
            "problems": [] if certified else ["human msd stiffness is not robust"]}


def test_format_certify_exact_lines():
    text = format_certify(_report(False))
    assert text.splitlines() == [
        "exotune certify — exotune-controller/1, 1000 Hz, delay 1.5 ms",
        "  golden vectors: 2000 samples, max error 3.2e-13 N·m",
        "  free (cuff free): stable (spectral radius 0.998765432)",
        "  locked joint:     inconclusive (spectral radius within rounding of 1) (spectral radius 1.000000000)",
        "  gain schedule, joint angle 0.5 rad (ratio 1.2): NOT robust for msd stiffness",
        "  msd stiffness [10, 500] N·m/rad: NOT robust; stable in [10, 320.5] N·m/rad",
        "  spring stiffness [100, 10000] N·m/rad: skipped (no rate)",
        "  method: exact z-domain",
        "NOT CERTIFIED:",
        "  - human msd stiffness is not robust",
    ]
    ok = format_certify({**_report(True), "gain_schedule": []}).splitlines()
    assert ok[-1] == "CERTIFIED" and not any(line.startswith("  gain schedule") for line in ok)
