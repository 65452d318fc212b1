"""exotune.text.margins: the lines of the margins section (continuous, sampled model of record,
plant uncertainty), every number with its unit."""

import math

from exotune.text.margins import format_margins

CONT = {"extra_delay_s": 0.0023456, "delay_s": 0.001, "extra_delay_samples": None,
        "critical": {"loop": "human mass", "parameter": "inertia", "value": 0.0123456789, "unit": "kg·m²",
                     "frequency_hz": 12.3456}, "verified": True, "note": "a note"}


def test_nothing_without_margins():
    assert format_margins(None) == [] and format_margins({}) == []


def test_continuous_latency_margin():
    assert format_margins({"latency": CONT}) == [
        "Margins:",
        "  latency margin: 2.346 ms of extra delay on top of T = 1 ms",
        "    critical: human mass at inertia = 0.0123457 kg·m², crossing at 12.35 Hz",
        "    note: a note",
        "    confirmed by root-count verdicts just below and above the margin",
    ]
    inf = format_margins({"latency": {"extra_delay_s": math.inf, "delay_s": 0.0, "extra_delay_samples": 2.0}})
    assert inf == ["Margins:", "  latency margin: ∞ (no extra delay destabilizes) of extra delay on top of T = 0 ms (2 samples)"]


def test_sampled_model_of_record_then_the_continuous_figure():
    lm = {"extra_delay_s": 0.002, "extra_delay_samples": 1.0, "delay_s": 0.001, "required_s": 0.003, "met": False,
          "critical": {"loop": "free"}}
    lines = format_margins({"model_of_record": "sampled-data at 1000 Hz", "latency": lm, "latency_continuous": CONT})
    assert lines[:4] == [
        "Margins:",
        "  latency margin (sampled-data at 1000 Hz, the model of record): 2 ms (1 sample) of extra delay on top of "
        "T = 1 ms; required ≥ 3 ms: NOT MET",
        "    critical: free",
        "  continuous-time figure (exact delay, no sampling; not what the runtime tolerates):",
    ]
    assert lines[4] == "  latency margin: 2.346 ms of extra delay on top of T = 1 ms"
    none = format_margins({"model_of_record": "m", "latency": {**lm, "extra_delay_s": None, "required_s": 0.001,
                                                                 "met": True, "critical": None}})
    assert none[1] == ("  latency margin (m, the model of record): no instability up to 200 samples of total delay of "
                       "extra delay on top of T = 1 ms; required ≥ 1 ms: met")


def test_plant_uncertainty_margin():
    pm = {"lower": 1.5, "upper": 2.25, "note": "budget spent",
          "witness": {"k": 2.25, "loop": "locked", "parameter": None, "value": None,
                      "deviations": {"motor_inertia": -0.1, "sea_stiffness": 0.0, "motor_damping": 0.05},
                      "rightmost_root": {"re": 0.5, "im": -30.0}}}
    assert format_margins({"plant_uncertainty": pm}) == [
        "Margins:",
        "  plant-uncertainty margin: 1.5 ≤ k* ≤ 2.25 × the declared relative plant uncertainty (lower bound "
        "certified, upper bound witnessed)",
        "    witness (unstable at k = 2.25): locked; plant motor_inertia -10 %, motor_damping +5 %, root 0.5 − 30j rad/s",
        "    note: budget spent",
    ]
    _head, line = format_margins({"plant_uncertainty": {"lower": 3.0, "upper": None}})
    assert "3 ≤ k* ≤ ∞ ×" in line
