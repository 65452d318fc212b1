"""The cost bounds of ``exotune simulate`` (docs/cli.md#simulate): one sample limit for all the
runs a scenario makes, decided before any run starts; a time budget (``--time-budget-s``) that
stops a run and writes nothing; the memory a run needs per sample; results unchanged by the
budget's checks."""

from __future__ import annotations

import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import exotune
from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.numerics.timebudget import time_budget
from exotune.simulation import SCENARIOS, load_for_simulation, simulate
from exotune.simulation.report import BYTES_PER_SAMPLE, MAX_SAMPLES, check_budget, run_scenario, scenario_runs

ROOT = Path(__file__).resolve().parents[2]
DESIGN = ROOT / "examples" / "scheduled.yaml"  # 1 kHz, with a DOB
FS = 1000.0


@pytest.fixture(scope="module")
def doc():
    return load_for_simulation(DESIGN)


def _counting(monkeypatch):
    """Count the engine's runs of :func:`run_scenario` (each a call of ``simulate``)."""
    import exotune.simulation.report as report

    calls = []
    real = report.simulate

    def counted(*args, **kw):
        calls.append(kw.get("series"))
        return real(*args, **kw)

    monkeypatch.setattr(report, "simulate", counted)
    return calls


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_the_planned_runs_are_the_runs_made(doc, name, monkeypatch):
    """The limit counts what the scenario will do: the runs of ``scenario_runs`` are the engine
    runs ``run_scenario`` makes (the dob-friction scenario of a file with a DOB makes four: the
    controller, the same without friction, without the DOB, and without both)."""
    calls = _counting(monkeypatch)
    run_scenario(doc, name, duration_s=0.05)
    assert len(calls) == len(scenario_runs(doc, SCENARIOS[name]))
    expected = {"dob-friction": 4, "saturation": 2, "backlash": 2, "locked-output": 1, "light-mass": 1}
    assert len(calls) == expected[name]


def test_a_scenario_whose_runs_together_exceed_the_limit_is_refused_before_any_run(doc, monkeypatch):
    """One run of dob-friction fits the limit, its four runs together do not: refused before the
    engine is called once, naming the scenario, its runs, the samples and the longest duration."""
    import exotune.simulation.report as report

    def never(*args, **kw):
        raise AssertionError("the engine ran before the limit was checked")

    monkeypatch.setattr(report, "simulate", never)
    per_run = MAX_SAMPLES // 4 + 1  # 4 × per_run > MAX_SAMPLES ≥ per_run
    duration = per_run / FS
    check_budget(FS, duration)  # one run of this length is accepted
    t = time.perf_counter()
    with pytest.raises(ConfigError) as ei:
        run_scenario(doc, "dob-friction", duration_s=duration)
    assert time.perf_counter() - t < 5.0
    assert ei.value.field == "duration"
    reason = ei.value.reason
    assert "scenario dob-friction makes 4 runs" in reason
    assert f"{per_run} samples per run" in reason and f"{4 * per_run} samples in all" in reason
    assert f"limit of {MAX_SAMPLES} samples per scenario" in reason
    longest = (MAX_SAMPLES // 4) / FS  # the longest run of which four fit the limit
    assert f"at most {longest:g} s at 1000 Hz" in reason
    check_budget(FS, longest, runs=4)  # and that length is accepted
    with pytest.raises(ConfigError):
        check_budget(FS, longest + 1.0 / FS, runs=4)


def test_the_cli_refuses_the_runs_together_with_exit_code_2():
    per_run = MAX_SAMPLES // 2 + 1000
    res = CliRunner().invoke(cli, ["simulate", str(DESIGN), "--scenario", "saturation",
                                   "--duration", f"{per_run / FS:g}"])
    assert res.exit_code == 2
    assert res.output.startswith("exotune: error: --duration:") and "makes 2 runs" in res.output
    assert "Traceback" not in res.output


def test_a_spent_budget_stops_the_cli_and_writes_nothing(tmp_path):
    """A long run with a tiny budget: exit code 2 naming --time-budget-s, nothing written."""
    out = tmp_path / "plots"
    t = time.perf_counter()
    res = CliRunner().invoke(cli, ["simulate", str(DESIGN), "--scenario", "locked-output", "--duration", "3000",
                                   "--time-budget-s", "0.05", "--plots", str(out)])
    assert time.perf_counter() - t < 30.0  # 3·10⁶ samples take far longer
    assert res.exit_code == 2, res.output
    assert res.output.startswith("exotune: error: --time-budget-s: ")
    assert "exceeded the time budget of 0.05 s and was stopped" in res.output
    assert res.output.rstrip().endswith("nothing was written") and "Traceback" not in res.output
    assert not out.exists()


def test_the_budget_option_is_validated_as_the_other_commands():
    for bad in ("0", "-1", "nan", "abc"):
        res = CliRunner().invoke(cli, ["simulate", str(DESIGN), "--scenario", "light-mass", "--time-budget-s", bad])
        ref = CliRunner().invoke(cli, ["analyze", str(DESIGN), "--time-budget-s", bad])
        assert res.exit_code == ref.exit_code == 2
        assert res.output == ref.output  # the same field, the same reason


def test_a_spent_budget_says_what_was_done(doc):
    """The message names the runs finished and where the current one stopped."""
    with pytest.raises(ConfigError) as ei:
        with time_budget(1e-9, "simulating scenario dob-friction", "shorten `duration` or lower the rate"):
            run_scenario(doc, "dob-friction", duration_s=2.0)
    assert ei.value.field == "time_budget_s"
    assert ei.value.reason.startswith("simulating scenario dob-friction exceeded the time budget of 1e-09 s")
    assert ("it had finished 0 of the 4 runs of scenario dob-friction (controller, frictionless, without_dob, "
            "frictionless_without_dob) and stopped the run controller at t = 0 s of 2 s") in ei.value.reason
    assert ei.value.reason.endswith("; nothing was written")


def test_the_engine_looks_at_the_clock_per_stretch_not_per_sample(doc, monkeypatch):
    import exotune.simulation.engine as engine

    calls = []
    monkeypatch.setattr(engine, "check_time", lambda: calls.append(1))
    n = 20_000
    sim = simulate(doc, SCENARIOS["locked-output"], duration_s=n / FS)
    assert sim["series"]["t"].size == n
    assert n / engine.CHUNK <= len(calls) <= n / 8  # at least once per CHUNK samples, far from every sample


def test_a_series_not_kept_takes_no_memory_and_changes_nothing(doc):
    sc = SCENARIOS["dob-friction"]
    full = simulate(doc, sc, duration_s=0.5)
    only = simulate(doc, sc, duration_s=0.5, series=("t", "theta_j"))
    assert set(only["series"]) == {"t", "theta_j"}
    for key in ("t", "theta_j"):
        np.testing.assert_allclose(only["series"][key], full["series"][key], rtol=1e-15, atol=0.0)


@pytest.mark.parametrize("name, duration", [("locked-output", 40.0), ("saturation", 20.0)])
def test_memory_per_sample_of_a_run_is_within_the_documented_bound(doc, name, duration):
    """tracemalloc's peak over a moderate scenario, per sample of each of its runs, stays within
    BYTES_PER_SAMPLE, so the largest accepted scenario (MAX_SAMPLES samples in all) stays
    under 1 GB."""
    run_scenario(doc, name, duration_s=0.05)  # one-time caches out of the measurement
    n = round(duration * FS)
    runs = len(scenario_runs(doc, SCENARIOS[name]))
    tracemalloc.start()
    try:
        r = run_scenario(doc, name, duration_s=duration)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert r.to_dict()["summary"]["samples"] == n
    per_sample = peak / (n * runs)
    assert 12 * 8 <= per_sample <= BYTES_PER_SAMPLE  # at least its twelve float64 series
    assert BYTES_PER_SAMPLE * MAX_SAMPLES <= 1e9


def _same(a, b):
    """Two reports equal: every number to rounding (the same computation), every text exactly."""
    if isinstance(a, dict):
        assert set(a) == set(b)
        for k in a:
            _same(a[k], b[k])
    elif isinstance(a, np.ndarray) or (isinstance(a, float) and isinstance(b, float)):
        np.testing.assert_allclose(a, b, rtol=1e-15, atol=0.0)
    else:
        assert a == b


@pytest.mark.parametrize("name", ["saturation", "dob-friction"])
def test_the_budget_changes_no_result(doc, name):
    """A run within a budget (the API's, and the command's) gives the report of a run outside any.
    The run outside a budget runs on the numpy engine, as every single-design command does (the
    API's and the command's runs too): on the compiled engine the loop's spectral radius comes from
    the compiled eigen-solver, equal to LAPACK's to ~1e-13, not to the bit."""
    from exotune.numerics.engine import numpy_engine

    with numpy_engine():
        plain = run_scenario(doc, name, duration_s=1.0)
    budgeted = exotune.simulate(DESIGN, name, duration=1.0, time_budget_s=600)
    _same(plain.to_dict(), budgeted.to_dict())
    _same(plain.runs, budgeted.runs)
    res = CliRunner().invoke(cli, ["simulate", str(DESIGN), "--scenario", name, "--duration", "1",
                                   "--time-budget-s", "600", "--json"])
    assert res.exit_code == 0
    assert res.output.strip() == plain.to_json().strip()


def test_a_long_run_is_drawn_thinned_keeping_every_extreme():
    """A figure of 6·10⁶ samples took 1.5 GB: the figures draw at most about PLOT_POINTS samples
    per run, keeping each bucket's extremes (a one-sample spike, the global peak, the last sample)."""
    from exotune.simulation.result import PLOT_POINTS, thinned

    n = 500_003
    t = np.arange(n) / FS
    x = np.sin(2 * np.pi * 3.0 * t) * np.exp(t / 200.0)
    y = np.zeros(n)
    y[123_457] = -7.0  # a one-sample spike
    s = thinned({"t": t, "x": x, "y": y})
    assert s["t"].size <= PLOT_POINTS and np.all(np.diff(s["t"]) > 0)
    assert s["x"].max() == x.max() and s["x"].min() == x.min() and s["y"].min() == -7.0
    assert s["t"][-1] == t[-1] and s["t"][0] == 0.0
    np.testing.assert_array_equal(np.interp(s["t"], t, x), s["x"])  # samples of the run, not new values
    short = {"t": t[:1000], "x": x[:1000]}
    assert thinned(short) is short
