"""exotune.text.verdicts: the exact lines of the sampled-data verdicts of record (``exotune analyze``)."""

from exotune.text.verdicts import format_verdicts

HUMAN = {"kind": "mass", "parameter": "inertia", "unit": "kg·m²", "range": [0.0, 2.0], "robust": True,
         "stable_intervals": [[0.0, 2.0]]}


def _sd(certifiable, **kw):
    sd = {"sample_rate_hz": 2000.0, "delay_s": 0.001, "delay_samples": 2.0, "certifiable": certifiable,
          "free_stable": True, "free_spectral_radius": 0.95, "locked_stable": False,
          "humans": [HUMAN], "environment": [],
          "latency_margin": {"extra_delay_s": 0.0025, "extra_delay_samples": 5.0, "method": "scan", "critical": None,
                             "predicted_continuous_s": 0.003},
          "requirements": {"latency_margin_s": 0.002, "source": "design file"},
          "problems": [] if certifiable else ["locked joint unstable"]}
    sd.update(kw)
    return sd


def test_not_certifiable_lines():
    assert format_verdicts(_sd(False)) == [
        "Sampled-data verdicts of record at 2000 Hz, delay 1 ms (2 samples) — the loop the exported controller "
        "runs, as certify judges it:",
        "  NOT CERTIFIABLE: export refuses this controller (--allow-uncertified writes it) and certify rejects it",
        "  free (cuff free): stable (spectral radius 0.950000000); locked joint: UNSTABLE",
        "  mass inertia [0, 2] kg·m²: robust; stable in [0, 2] kg·m²",
        "  latency margin (sampled-data): 2.5 ms (5 samples); predicted continuous 3 ms; required 2 ms (design file)",
        "  - locked joint unstable",
    ]


def test_certifiable_with_a_gain_schedule_and_no_requirement():
    sd = _sd(True, gain_schedule=[{"joint_angle_rad": -0.25, "ratio": 0.8, "robust": True, "not_robust": []}],
             requirements={"latency_margin_s": None, "source": "none given"})
    lines = format_verdicts(sd)
    assert lines[1] == "  CERTIFIABLE: export writes this controller and certify accepts it"
    assert "  gain schedule, joint angle -0.25 rad (ratio 0.8): robust" in lines
    assert lines[-1] == ("  latency margin (sampled-data): 2.5 ms (5 samples); predicted continuous 3 ms; "
                         "no requirement in the file (none given)")
    assert not any(line.startswith("  - ") for line in lines)
