"""``exotune excite`` (issue 26 item 6): a Schroeder-phased multisine over a band — energy exactly on
the chosen lines over whole periods, a crest factor well below random phases, periodic, of the
amplitude asked; the CSV is a log ``identify`` reads, and a plant simulated with it as command
(tests/identification/simulated_logs.py) is identified; bad options exit 2 naming the option
with nothing written."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

import exotune
from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.identification import identify_plant, log_from_columns, read_log, schroeder_multisine
from identification.simulated_logs import TRUE, command_log


def _spectrum(e, periods):
    """|DFT|² of ``periods`` whole periods of the command, and the bins of its lines."""
    _t, u = e.signal()
    x = u[: periods * e.period_samples]
    P = np.abs(np.fft.rfft(x)) ** 2
    return P, np.asarray(e.harmonics) * periods


@pytest.mark.parametrize("lines", ["all", "odd", "random-odd", "log"])
def test_energy_lies_exactly_on_the_chosen_lines(lines):
    e = schroeder_multisine(1000.0, 0.7, 45.0, rms_nm=1.0, period_s=4.0, periods=3, lines=lines)
    P, bins = _spectrum(e, 3)
    on = np.zeros(P.size, bool)
    on[bins] = True
    assert P[~on].sum() < 1e-24 * P.sum()  # nothing off the lines (rounding only)
    assert np.allclose(P[bins], P[bins][0], rtol=1e-9)  # a flat spectrum over the lines
    f = e.lines_hz
    assert f.min() >= 0.7 and f.max() <= 45.0 and e.resolution_hz == pytest.approx(0.25)
    assert e.rms_nm == pytest.approx(1.0, rel=1e-12)
    if lines == "odd":
        assert all(k % 2 == 1 for k in e.harmonics)
    if lines == "random-odd":  # one odd line in each group of three left out, reproducibly
        odd = [k for k in range(3, 181) if k % 2]
        assert len(e.harmonics) == len(odd) - len(odd) // 3
        again = schroeder_multisine(1000.0, 0.7, 45.0, rms_nm=1.0, period_s=4.0, periods=3, lines=lines, seed=0)
        assert again.harmonics == e.harmonics
        other = schroeder_multisine(1000.0, 0.7, 45.0, rms_nm=1.0, period_s=4.0, periods=3, lines=lines, seed=1)
        assert other.harmonics != e.harmonics
    if lines == "log":  # 20 lines per decade (every harmonic where they would be closer)
        steps = np.diff(np.log10(f))
        assert np.all((steps <= 1 / 20 + 0.02) | np.isclose(np.diff(f), 0.25))
        assert np.all(np.abs(steps[-5:] - 1 / 20) < 0.01)


def test_schroeder_crest_factor_is_well_below_random_phases():
    e = schroeder_multisine(1000.0, 1.0, 20.0, peak_nm=2.0, periods=2)
    assert len(e.harmonics) == 20 and e.crest_factor < 2.0
    rng = np.random.default_rng(0)
    random = []
    for _ in range(200):
        X = np.zeros(501, complex)
        X[1:21] = np.exp(1j * rng.uniform(0, 2 * np.pi, 20))
        x = np.fft.irfft(X, 1000)
        random.append(np.max(np.abs(x)) / np.sqrt(np.mean(x * x)))
    assert e.crest_factor < 0.7 * np.mean(random), (e.crest_factor, np.mean(random))
    # the phases are Schroeder's: −π m(m+1)/K for the m-th of K consecutive lines
    m = np.arange(20)
    want = -np.pi * m * (m + 1) / 20
    assert np.allclose(np.exp(1j * np.asarray(e.phases_rad)), np.exp(1j * want), atol=1e-12)
    X = np.fft.rfft(e.period)[list(e.harmonics)]
    assert np.allclose(np.angle(X / np.exp(1j * want)), 0, atol=1e-9)


def test_the_command_is_periodic_with_the_amplitude_asked():
    e = schroeder_multisine(2000.0, 2.0, 100.0, peak_nm=3.0, period_s=0.5, duration_s=2.2)
    t, u = e.signal()
    N = e.period_samples
    assert e.periods == 4 and u.size == 4 * N == 4000 and t[1] == 1 / 2000.0
    assert np.array_equal(u[N:], u[:-N])
    assert np.max(np.abs(u)) == pytest.approx(3.0, rel=1e-14)
    default = schroeder_multisine(1000.0, 0.5, 10.0, peak_nm=1.0)
    assert default.period_s == 2.0 and default.periods == 10  # 1/f_lo, whole periods making 20 s


def test_identify_recovers_the_plant_from_a_log_excited_with_it(tmp_path):
    """The written CSV is the command column of a log: simulated as the rig would run it (held,
    applied one sample late), logged with sensor noise, identified."""
    fs = 1000.0
    out = tmp_path / "exc.csv"
    res = CliRunner().invoke(cli, ["excite", "-o", str(out), "--sample-rate-hz", "1000", "--f-lo-hz", "0.2",
                                   "--f-hi-hz", "60", "--rms-nm", "2", "--period-s", "5", "--periods", "3"])
    assert res.exit_code == 0, res.output
    side = json.loads((tmp_path / "exc.json").read_text())
    assert side["columns"] == {"t": {"unit": "s", "meaning": "sample time"},
                               "tau_cmd": {"unit": "N·m", "meaning": "motor torque command, held between samples"}}
    assert out.read_text().splitlines()[0] == "t,tau_cmd"
    import csv

    rows = list(csv.reader(out.open()))
    t = np.array([float(r[0]) for r in rows[1:]])
    cmd = np.array([float(r[1]) for r in rows[1:]])
    assert t.size == 15000 and np.allclose(np.diff(t), 1e-3)
    cols = command_log(cmd, fs, delay=1, seed=3)
    cols["t"] = t
    path = tmp_path / "log.csv"
    names = list(cols)
    path.write_text(",".join(names) + "\n" + "".join(",".join(repr(float(cols[c][i])) for c in names) + "\n"
                                                     for i in range(t.size)))
    r = identify_plant(read_log(path, delay_s=1e-3))
    for k, v in TRUE.items():
        assert abs(r[k].value - v) < 4 * r[k].std_error and r[k].relative_std_error < 0.01, (k, r[k])
    # noise-free: the plant itself
    clean = identify_plant(log_from_columns(dict(command_log(cmd, fs, delay=1, noise=False), t=t), delay_s=1e-3))
    for k, v in TRUE.items():
        assert clean[k].value == pytest.approx(v, rel=1e-6), k


@pytest.mark.parametrize("args, option", [
    (["--f-hi-hz", "500"], "--f-hi-hz"),  # at the Nyquist frequency
    (["--f-hi-hz", "700"], "--f-hi-hz"),
    (["--f-lo-hz", "0"], "--f-lo-hz"),
    (["--f-lo-hz", "-1"], "--f-lo-hz"),
    (["--f-lo-hz", "40"], "--f-lo-hz"),  # not below f_hi
    (["--peak-nm", "0"], "--peak-nm"),
    (["--peak-nm", "-2"], "--peak-nm"),
    (["--peak-nm", "nan"], "--peak-nm"),
    (["--rms-nm", "1"], "--peak-nm"),  # both amplitudes
    (["--period-s", "0.01"], "--period-s"),  # 100 Hz resolution: no line in 0.5–40 Hz
    (["--periods", "0"], "--periods"),
    (["--duration-s", "1"], "--duration-s"),  # shorter than the 2 s period
    (["--periods", "2", "--duration-s", "10"], "--duration-s"),
    (["--seed", "1"], "--seed"),  # all lines: nothing drawn
    (["--lines", "sparse"], "--lines"),
    (["--sample-rate-hz", "abc"], "--sample-rate-hz"),
    (["--period-s", "1e308"], "--period-s"),  # overflows a sample count
    (["--peak-nm", "1e308"], "--peak-nm"),  # beyond what identify reads back (check the units)
])
def test_bad_options_exit_2_naming_the_option_and_write_nothing(tmp_path, args, option):
    base = {"--sample-rate-hz": "1000", "--f-lo-hz": "0.5", "--f-hi-hz": "40", "--peak-nm": "2"}
    for k, v in zip(args[::2], args[1::2]):
        base[k] = v
    out = tmp_path / "exc.csv"
    res = CliRunner().invoke(cli, ["excite", "-o", str(out)] + [x for kv in base.items() for x in kv])
    assert res.exit_code == 2, res.output
    line = res.output.strip()
    assert line.startswith(f"exotune: error: {option}") and "\n" not in line, res.output
    assert "`" not in line and "_hz" not in line and "_nm" not in line  # options, not the API's keywords
    assert list(tmp_path.iterdir()) == []


def test_the_api_names_keywords_and_the_command_line_options(tmp_path):
    """One error, two audiences: the library's reason quotes its keywords in backticks, the
    command line prints the options that feed them."""
    with pytest.raises(ConfigError) as e:
        exotune.excite(sample_rate_hz=1000.0, f_lo_hz=0.5, f_hi_hz=40.0, peak_nm=2.0, periods=2, duration_s=10.0)
    assert str(e.value) == "duration_s: give `periods` or `duration_s`, not both"
    res = CliRunner().invoke(cli, ["excite", "-o", str(tmp_path / "e.csv"), "--sample-rate-hz", "1000", "--f-lo-hz", "0.5",
                                   "--f-hi-hz", "40", "--peak-nm", "2", "--periods", "2", "--duration-s", "10"])
    assert res.exit_code == 2
    assert res.output.strip() == "exotune: error: --duration-s: give --periods or --duration-s, not both"
    assert list(tmp_path.iterdir()) == []


def test_text_and_json_report_crest_factor_resolution_and_lines_with_units(tmp_path):
    out = tmp_path / "e.csv"
    res = CliRunner().invoke(cli, ["excite", "-o", str(out), "--sample-rate-hz", "1000", "--f-lo-hz", "1",
                                   "--f-hi-hz", "20", "--peak-nm", "2"])
    assert res.exit_code == 0, res.output
    assert "crest factor (peak/RMS): 1.763 [–]" in res.output
    assert "frequency resolution 1/period: 1 Hz" in res.output and "20 excited lines" in res.output
    assert "peak 2 N·m" in res.output
    res = CliRunner().invoke(cli, ["excite", "-o", str(out), "--sample-rate-hz", "1000", "--f-lo-hz", "1",
                                   "--f-hi-hz", "20", "--peak-nm", "2", "--json"])
    d = json.loads(res.output)
    assert d["lines"] == 20 and d["units"]["crest_factor"] == "–" and d["units"]["resolution_hz"] == "Hz"
    assert d == json.loads((tmp_path / "e.json").read_text())
    api = exotune.excite(tmp_path / "f.csv", sample_rate_hz=1000.0, f_lo_hz=1.0, f_hi_hz=20.0, peak_nm=2.0)
    assert api.to_csv() == out.read_text() and (tmp_path / "f.json").exists()
    with pytest.raises(ConfigError) as e:
        exotune.excite(sample_rate_hz=1000.0, f_lo_hz=1.0, f_hi_hz=20.0)
    assert e.value.field == "peak_nm"  # the API names its keywords; the command line its options (above)
    assert "`peak_nm` and `rms_nm`" in e.value.reason


def test_frequency_responses_of_a_periodic_command_are_read_at_its_lines():
    """A log excited by exotune excite (period 2048 samples): the responses are averaged over whole
    periods and read at the lines only (a Hann window over two periods does not mix them); with
    the right model no parameter departs beyond 3 SE and nothing is warned (with sensor noise:
    noise-free, the simulation error is the discretization's, correlated with the input); noise-free,
    the responses give the parameters to 1e-4 (median; the person's own torque, not periodic, leaks into
    the lowest lines)."""
    from exotune.identification import validate_plant
    from exotune.identification.frf import command_period

    e = schroeder_multisine(1000.0, 0.5, 40.0, rms_nm=2.0, period_s=2.048, periods=12)
    t, u = e.signal()
    for noise in (True, False):
        cols = dict(command_log(u, 1000.0, delay=1, noise=noise, seed=4), t=t)
        log = log_from_columns(cols, delay_s=1e-3)
        r = validate_plant(identify_plant(log), log)
        assert not noise or not (r.warnings or r.validation.warnings), r.validation.warnings
        motor = r.validation.frequency_responses[0]
        lines = motor.frequency_hz[motor.coherent] / e.resolution_hz
        assert motor.coherent.sum() >= 70 and np.allclose(lines, np.round(lines), atol=1e-6)
        for fr in r.validation.frequency_responses:
            for p in fr.local:
                assert p.relative_excess <= 3 * r[p.key].relative_std_error, (fr.name, p.symbol, p.relative_excess)
                if not noise:
                    dev = np.abs(p.values[fr.coherent] / p.estimate - 1)
                    assert np.max(dev) < 1e-2 and np.median(dev) < 1e-4, (fr.name, p.symbol)
    assert command_period(np.concatenate([[0.0], u]), 1) == 2048 and command_period(cols["theta_m"]) is None


@pytest.mark.parametrize("kw", [{"peak_nm": 1e-200}, {"rms_nm": 1e-300}, {"peak_nm": 1e-10}])
def test_an_amplitude_no_actuator_resolves_is_refused(kw):
    """1e-200 N·m made the RMS underflow to 0: a ZeroDivisionError in the crest factor (a
    traceback from `exotune excite`). Amplitudes below 1e-9 N·m are refused, naming the option."""
    from exotune.errors import ConfigError
    from exotune.identification.excite import schroeder_multisine

    with pytest.raises(ConfigError) as ei:
        schroeder_multisine(1000.0, 1.0, 40.0, **kw)
    assert ei.value.field == next(iter(kw)) and "below 1e-09 N·m" in ei.value.reason
    assert schroeder_multisine(1000.0, 1.0, 40.0, peak_nm=1e-9).crest_factor > 1


def test_the_default_period_puts_its_first_line_in_the_band():
    """1.5–2.5 Hz at 1000 Hz: the default period 1/f_lo was rounded to 667 samples, whose first
    line 1.49925 Hz lies below the band, and the command refused its own default. It is now
    rounded down (666 samples, 1.5015 Hz); a period that is a whole number of samples is kept."""
    e = schroeder_multisine(1000.0, 1.5, 2.5, rms_nm=1.0)
    assert e.period_samples == 666 and e.harmonics == (1,) and 1.5 <= e.lines_hz[0] <= 2.5
    assert schroeder_multisine(1000.0, 0.5, 40.0, peak_nm=1.0).period_samples == 2000
    assert schroeder_multisine(1000.0, 3.0, 40.0, peak_nm=1.0).period_samples == 333
    assert schroeder_multisine(1000.0, 0.1, 40.0, peak_nm=1.0, period_s=6.6667).period_samples == 6667  # given: rounded
    for fs, lo, hi in [(1000.0, 1.5, 2.5), (1000.0, 0.7, 0.75), (977.0, 3.3, 3.4), (1e4, 7.77, 7.8)]:
        f = schroeder_multisine(fs, lo, hi, peak_nm=1.0).lines_hz
        assert f.size >= 1 and lo <= f.min() and f.max() <= hi, (fs, lo, hi)


def test_the_default_period_on_the_command_line(tmp_path):
    out = tmp_path / "a.csv"
    res = CliRunner().invoke(cli, ["excite", "-o", str(out), "--sample-rate-hz", "1000", "--f-lo-hz", "1.5",
                                   "--f-hi-hz", "2.5", "--rms-nm", "1"])
    assert res.exit_code == 0, res.output
    assert "31 periods of 0.666 s (666 samples)" in res.output
    assert "1 excited line (all), 1.5015 Hz" in res.output


@pytest.mark.parametrize("args, option", [
    (["--sample-rate-hz", "1e7"], "--sample-rate-hz"),  # 20 s at 10 MHz: 2e8 samples
    (["--f-lo-hz", "1e-4"], "--f-lo-hz"),  # two periods of 1e7 samples
    (["--f-lo-hz", "1e-4", "--period-s", "6000"], "--period-s"),  # two periods of 6e6 samples
])
def test_a_default_length_over_the_limit_names_an_option_that_was_given(tmp_path, args, option):
    """At 10 MHz the default 20 s exceed the 1e7 samples written: the error named --duration-s,
    which was not given. It now names the option that makes the default too long and says which
    options shorten it."""
    base = {"--sample-rate-hz": "1000", "--f-lo-hz": "1", "--f-hi-hz": "40", "--peak-nm": "1"}
    for k, v in zip(args[::2], args[1::2]):
        base[k] = v
    res = CliRunner().invoke(cli, ["excite", "-o", str(tmp_path / "e.csv")] + [x for kv in base.items() for x in kv])
    assert res.exit_code == 2, res.output
    line = res.output.strip()
    assert line.startswith(f"exotune: error: {option}: the default length, whole periods making 20 s (at least 2), ")
    assert line.endswith("at most 10000000 samples are written; give fewer --periods or a shorter --duration-s")
    assert list(tmp_path.iterdir()) == []


def test_a_length_at_the_limit_is_written(tmp_path):
    """The edge of the refusals above: one period of 1 s at 10 MHz is exactly the 1e7 samples
    allowed, and is written (once here: writing 1e7 rows takes tens of seconds)."""
    res = CliRunner().invoke(cli, ["excite", "-o", str(tmp_path / "e.csv"), "--sample-rate-hz", "1e7", "--f-lo-hz",
                                   "1", "--f-hi-hz", "40", "--peak-nm", "1", "--periods", "1"])
    assert res.exit_code == 0 and "1 period of 1 s (10000000 samples)" in res.output


def test_periods_and_seed_show_their_range_in_help(tmp_path):
    """--periods and --seed showed "[x<=None]" (click's text for an unbounded range)."""
    text = CliRunner().invoke(cli, ["excite", "--help"]).output
    assert "None" not in text
    flat = " ".join(text.split())
    assert "at least 2). [x>=1]" in flat and "(default 0). [x>=0]" in flat
    res = CliRunner().invoke(cli, ["excite", "-o", str(tmp_path / "x.csv"), "--sample-rate-hz", "1000", "--f-lo-hz", "1",
                                   "--f-hi-hz", "40", "--peak-nm", "1", "--lines", "random-odd", "--seed", "-1"])
    assert res.exit_code == 2 and res.output.startswith("exotune: error: --seed: -1 is not in the range x>=0")
