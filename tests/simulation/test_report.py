"""exotune.simulation.report: a run's summary on hand-made series (verdict, metrics by their
definitions, null metrics with the reason for a growing run), the run budget, run_scenario."""

import math

import numpy as np
import pytest

from exotune.controllerfile import build_export
from exotune.errors import ConfigError
from exotune.simulation.report import check_budget, check_run_options, run_scenario, summarize
from exotune.simulation.result import SimulationRun
from exotune.simulation.scenarios import SCENARIOS
from exotune.simulation.verdict import LoopSpectrum

from paper_design import paper_design

FS = 1000.0
T = np.arange(0.0, 4.0, 1 / FS)
MARGINAL = 0.05


@pytest.fixture(scope="module")
def paper_doc():
    """examples/paper.yaml's controller at 1 kHz, built once for the module (run_scenario only reads
    it): the sections the runtime executes, as ``exotune simulate`` builds a design file's
    (``build_export(..., analyses=False)``). The sampled-data predictions of a written controller
    file (``paper_design.paper_controller``) are not computed: neither the simulator nor these
    tests read them (the runs are the same bit for bit)."""
    return build_export(paper_design(sample_rate_hz=FS), FS, analyses=False)


def _sim(tau_s, tau_c, theta_h=None, diverged=None):
    z = np.zeros(T.size)
    return {"sample_rate_hz": FS, "start": "bumpless", "diverged": diverged,
            "series": {"t": T, "tau_s": tau_s, "tau_c": tau_c, "theta_h": z if theta_h is None else theta_h,
                       "theta_j": z, "tau_m": 3.0 + 0 * T, "tau_cmd": -4.0 + 0 * T}}


def test_locked_output_metrics_by_their_definitions():
    sc = SCENARIOS["locked-output"]
    tc = 5.0 + 0 * T
    ts = -35.0 + np.exp(-2.0 * T) * np.sin(40 * T)  # settles at −35 N·m: (τ_c − τ_s)/τ_c = 8
    sm = summarize(_sim(ts, tc), sc, 8.0, 0.99)
    assert sm["verdict"] == "decaying" and not sm["diverged"]
    assert sm["samples"] == T.size and sm["duration_s"] == {"value": 4.0, "unit": "s"}
    assert sm["steady_cuff_torque"]["value"] == pytest.approx(5.0)
    assert sm["delivered_amplification"]["value"] == pytest.approx(8.0, rel=1e-4)
    assert sm["delivered_amplification"]["design_alpha"] == 8.0
    assert abs(sm["amplification_error"]["value"]) < 1e-4
    assert sm["peak_motor_torque"] == {"value": 3.0, "unit": "N·m"} and sm["peak_command"]["value"] == 4.0
    rho = sm["loop_spectral_radius"]
    assert rho["value"] == 0.99 and rho["growth_rate_per_s"] == pytest.approx(FS * math.log(0.99))


def test_a_growing_run_has_no_metrics_and_says_why():
    sc = SCENARIOS["light-mass"]
    grow = np.exp(0.8 * T) * np.sin(60 * T)
    sm = summarize(_sim(grow, grow, theta_h=1e-3 * grow), sc, 8.0, 1.001)
    assert sm["verdict"] == "growing" and sm["diverged"]
    assert sm["envelope_growth_rate"]["value"] == pytest.approx(0.8, abs=0.05)
    assert sm["metrics_null_reason"].startswith("growing run: the oscillation of tau_")
    assert sm["peak_motor_torque"]["value"] is None and sm["cuff_oscillation_start_rad"]["value"] is None
    stopped = summarize(_sim(grow, grow, diverged="an angle beyond 1e6 rad"), sc, 8.0, None)
    assert stopped["stopped"] == "an angle beyond 1e6 rad"
    assert stopped["metrics_null_reason"] == "growing run: an angle beyond 1e6 rad"
    assert stopped["loop_spectral_radius"]["growth_rate_per_s"] is None


def _short_sim(n=16, rate=-34.0, f=44.3):
    t = np.arange(n) / FS
    s = np.exp(rate * t) * np.sin(2 * np.pi * f * t)
    z = np.zeros(n)
    return {"sample_rate_hz": FS, "start": "bumpless", "diverged": None,
            "series": {"t": t, "tau_s": s, "tau_c": s, "theta_h": 1e-3 * s, "theta_j": z, "tau_m": 1.0 + z,
                       "tau_cmd": 1.0 + z}}


def test_a_short_run_of_a_growing_loop_is_not_decaying():
    """h8 item 3: 16 samples whose envelope decays, while the loop's spectral radius is 1.00311 with a
    44.3 Hz dominant oscillation (two periods: 45 ms): the summary said "decaying". The eigenvalues
    decide, and the summary says so in words."""
    sp = LoopSpectrum(1.00311, FS, 44.29, 1.00311)
    sm = summarize(_short_sim(), SCENARIOS["light-mass"], 8.0, sp)
    assert sm["envelope_growth_rate"]["value"] < -MARGINAL  # the envelope alone says decaying
    assert sm["verdict"] == "growing" and sm["verdict_basis"] == "spectral_radius" and sm["diverged"]
    why = sm["verdict_reason"]
    assert why.startswith("the linearized loop's spectral radius 1.00311 > 1 (growth 3.105 1/s) decides: "
                          "the run (0.016 s, 16 samples) is shorter than 2 periods of the linearized loop's "
                          "dominant oscillation at 44.29 Hz (2 × 0.02258 s = 0.04516 s)"), why
    assert sm["metrics_null_reason"] == "growing run: the linearized loop grows (spectral radius 1.00311 > 1)"
    assert sm["peak_motor_torque"]["value"] is None
    lsr = sm["loop_spectral_radius"]
    assert lsr["dominant_oscillation_hz"] == 44.29 and lsr["dominant_oscillation_period_s"] == pytest.approx(1 / 44.29)


def test_a_short_run_of_a_stable_loop_is_inconclusive():
    sp = LoopSpectrum(0.996, FS, 9.86, 0.98)
    sm = summarize(_short_sim(n=50, f=9.86), SCENARIOS["light-mass"], 8.0, sp)
    assert sm["verdict"] == "inconclusive" and sm["verdict_basis"] == "none" and not sm["diverged"]
    assert sm["verdict_reason"].startswith("the run (0.05 s, 50 samples) is shorter than 2 periods of the linearized "
                                           "loop's dominant oscillation at 9.86 Hz (2 × 0.1014 s = 0.2028 s): its "
                                           "envelope (the oscillation of tau_")
    assert sm["verdict_reason"].endswith("cannot tell growth from decay; a run of at least 0.2028 s can be judged")
    assert sm["metrics_null_reason"].startswith("inconclusive run: the run is too short to be judged")
    assert sm["peak_motor_torque"]["value"] is None and sm["cuff_oscillation_start_rad"]["value"] is None
    long = summarize(_short_sim(n=400, f=9.86), SCENARIOS["light-mass"], 8.0, sp)  # 0.4 s ≥ 0.2028 s
    assert long["verdict"] == "decaying" and long["verdict_basis"] == "envelope"
    assert long["verdict_reason"].endswith("the run of 0.4 s lasts at least 2 periods of the linearized loop's "
                                           "dominant oscillation at 9.86 Hz (2 × 0.1014 s = 0.2028 s)")
    assert long["peak_motor_torque"]["value"] == 1.0


def test_the_run_budget():
    check_budget(1000.0, 6.0)
    with pytest.raises(ConfigError) as ei:
        check_budget(1000.0, 1e6)
    assert ei.value.field == "duration"
    assert ei.value.reason == ("1e+06 s at 1000 Hz is 1000000000 samples per run; the scenario makes 1 run, "
                               "1000000000 samples in all, over the limit of 6000000 samples per scenario (at most "
                               "6000 s at 1000 Hz for its 1 run; shorten `duration` or lower the rate)")


def test_the_run_budget_gives_exact_counts_near_the_limit():
    """10001 s at 1 kHz read "is 1e+07 samples; … limited to 1e+07 samples": both counts rounded
    to the same text. Now both are exact, and the limit is also given in seconds at the rate."""
    with pytest.raises(ConfigError) as ei:
        check_budget(1000.0, 6001.0)
    assert ei.value.reason == ("6001 s at 1000 Hz is 6001000 samples per run; the scenario makes 1 run, 6001000 "
                               "samples in all, over the limit of 6000000 samples per scenario (at most 6000 s at "
                               "1000 Hz for its 1 run; shorten `duration` or lower the rate)")
    check_budget(1000.0, 6000.0004)  # 6000000.4 samples: the run's count (rounded) is within the limit
    with pytest.raises(ConfigError) as ei:
        check_budget(1e7, 1e300)  # beyond any float count: no 300-digit integer
    assert "about 1e+307 samples" in ei.value.reason


def test_the_shortest_run_is_counted_as_the_run_counts_its_samples():
    """0.0159999 s at 1 kHz read "is 16 samples; a verdict needs a run of at least 16 samples": the
    check compared 15.9999 with 16 and the message rounded it. The run has round(duration × rate)
    samples (16 here), so the check counts the same way and the message gives that count."""
    check_budget(1000.0, 0.0159999)  # 16 samples: long enough
    check_budget(1000.0, 0.016)
    with pytest.raises(ConfigError) as ei:
        check_budget(1000.0, 0.0154)  # 15 samples
    assert ei.value.reason == ("0.0154 s at 1000 Hz is 15 samples; a verdict needs a run of at least 16 samples "
                               "(0.016 s at this rate)")
    with pytest.raises(ConfigError) as ei:
        check_budget(1000.0, 0.0024)
    assert ei.value.reason.startswith("0.0024 s at 1000 Hz is 2 samples;")


def test_run_scenario_returns_the_typed_run(paper_doc):
    run = run_scenario(paper_doc, "locked-output", duration_s=1.0)
    assert isinstance(run, SimulationRun) and run.scenario == "locked-output"
    rep = run.to_dict()
    assert rep["summary"]["verdict"] in ("decaying", "marginal") and "runs" not in rep
    assert run.runs and all("series" in r for r in run.runs.values())


@pytest.mark.parametrize("kw, field, reason", [
    ({"name": "nope"}, "scenario", "unknown scenario 'nope' (known: locked-output,"),
    ({"name": ["locked-output"]}, "scenario", "unknown scenario ['locked-output']"),  # was a bare TypeError
    ({"start": "warm"}, "start", "must be one of bumpless, zero, got 'warm'"),
    ({"duration_s": True}, "duration", "expected a number of seconds, got True"),
    ({"duration_s": "2"}, "duration", "expected a number of seconds, got '2'"),
    ({"duration_s": math.nan}, "duration", "must be a finite number"),
    ({"duration_s": -1.0}, "duration", "must be > 0"),
    ({"human_inertia": False}, "human_inertia", "expected a number of kg·m², got False"),
    ({"human_inertia": "0.02"}, "human_inertia", "expected a number of kg·m², got '0.02'"),
])
def test_run_options_are_refused_naming_their_keyword(kw, field, reason, paper_doc):
    args = {"name": "locked-output", **kw}
    with pytest.raises(ConfigError) as ei:
        check_run_options(**args)
    assert ei.value.field == field and reason in ei.value.reason
    with pytest.raises(ConfigError) as ei:  # run_scenario checks them itself, before any run
        run_scenario(paper_doc, args.pop("name"), **args)
    assert ei.value.field == field


def test_run_options_as_numbers():
    sc, m, d = check_run_options("light-mass", "zero", 1, 2)
    assert sc is SCENARIOS["light-mass"] and (m, d) == (1.0, 2.0) and type(m) is float and type(d) is float
    assert check_run_options(SCENARIOS["backlash"])[0] is SCENARIOS["backlash"]
