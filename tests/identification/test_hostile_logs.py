"""Hostile input to ``exotune identify`` (a fuzz's findings): every parameter of an equation fixed,
the same run given twice or validated on, one parameter fixed to two values under its two names,
a filter corner far too low, reordered time stamps and comment lines in the CSV. Each is either
handled as a control engineer expects or refused with one line naming the option and the reason.
Logs simulated independently of exotune (tests/identification/simulated_logs.py)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.identification import identify_plant, log_from_columns, read_log
from exotune.identification.estimate import parse_fix
from exotune.identification.regress import Design
from identification.simulated_logs import TRUE, held_logs

FS = 1000.0
MOTOR = {"motor_inertia": TRUE["motor_inertia"], "motor_damping": TRUE["motor_damping"]}


def _csv(path, cols, head=""):
    names = list(cols)
    path.write_text(head + ",".join(names) + "\n" + "".join(",".join(repr(float(x)) for x in r) + "\n"
                                                             for r in zip(*(cols[n] for n in names))))
    return path


@pytest.fixture(scope="module")
def held():
    return held_logs(2, FS, 6.0, seed0=71)


def _run(*args):
    res = CliRunner().invoke(cli, ["identify", *map(str, args)])
    return res.exit_code, res.output


# --- every parameter of an equation fixed -------------------------------------------------------

@pytest.mark.parametrize("delay_s", [1e-3, "auto"])
def test_every_motor_parameter_fixed_identifies_the_others(held, delay_s):
    """J_m and B_m fixed (a held command, so the delay is checked on the motor equation, which has
    nothing left to estimate): K_s, J_j, K_c identified as usual; the motor equation's fit is still
    reported, its R² that of the equation as written; the delay estimated (auto)."""
    r = identify_plant(log_from_columns(held[0], delay_s=delay_s), fix=MOTOR)
    assert r["motor_inertia"].fixed and r["motor_damping"].fixed
    for k in ("sea_stiffness", "joint_inertia", "cuff_stiffness"):
        assert abs(r[k].value - TRUE[k]) < 4 * r[k].std_error, k
    motor = r.fits[0]
    assert motor.parameters == () and motor.covariance == () and motor.r2 > 0.9999
    assert r.delay["samples"] == 1 and r.complete
    assert "τ_s + τ_m: R² " in r.to_text() and "(every parameter fixed)" in r.to_text()


def test_fixed_values_are_checked_by_the_residual(held):
    """Fixing J_m wrong (and B_m) leaves a larger motor-equation residual than fixing it right."""
    log = log_from_columns(held[0], delay_s=1e-3)
    right = identify_plant(log, fix=MOTOR).fits[0]
    wrong = identify_plant(log, fix=dict(MOTOR, motor_inertia=2 * TRUE["motor_inertia"])).fits[0]
    assert wrong.rms_residual > 10 * right.rms_residual and wrong.r2 < right.r2


def test_every_motor_parameter_fixed_on_the_command_line(tmp_path, held):
    log = _csv(tmp_path / "log.csv", held[0])
    out = tmp_path / "p.yaml"
    code, text = _run(log, "--fix", "J_m=0.44", "--fix", "B_m=17.9", "--delay-s", "0.001", "-o", out)
    assert code == 0, text
    sec = yaml.safe_load(out.read_text())
    assert sec["plant"]["motor_inertia"] == 0.44 and sec["uncertainty"]["motor_damping"] == 0
    assert sec["plant"]["sea_stiffness"] == pytest.approx(TRUE["sea_stiffness"], rel=1e-3)


def test_everything_fixed_refuses_to_write_and_reports_the_residuals(tmp_path, held):
    log = _csv(tmp_path / "log.csv", held[0])
    fixes = [a for k in ("J_m=0.44", "B_m=17.9", "K_s=1180", "J_j=0.29", "K_c=300") for a in ("--fix", k)]
    out = tmp_path / "p.yaml"
    code, text = _run(log, *fixes, "--delay-s", "0.001", "-o", out)
    assert code == 2 and text.startswith("exotune: error: --fix: every plant parameter") and text.count("\n") == 1, text
    assert "-o" in text and not out.exists()
    code, text = _run(log, *fixes, "--delay-s", "0.001")
    assert code == 0 and text.count("(every parameter fixed)") == 4, text


def test_a_design_without_free_columns_fits_the_offset_and_transients():
    """An equation with nothing left to estimate: its offset and transients, per log, by least squares."""
    rng = np.random.default_rng(5)
    ys, modes, ref = [], [], []
    for n, c in ((700, 0.5), (400, -2.0)):
        t = np.arange(n) / 1000.0
        M = np.vstack([np.exp(-50 * t[:200]), t[:200] * np.exp(-50 * t[:200]), t[:200] ** 2 * np.exp(-50 * t[:200])])
        y = c + np.r_[np.array([1.0, -3.0, 40.0]) @ M, np.zeros(n - 200)] + 0.01 * rng.normal(size=n)
        X = np.column_stack([np.ones(n), np.hstack([M, np.zeros((3, n - 200))]).T])
        ref.append(np.linalg.lstsq(X, y, rcond=None)[0])
        ys.append(y)
        modes.append(M)
    d = Design([], modes, [y.size for y in ys])
    fit = d.fit(ys)
    assert fit.beta.size == 0 and d.n == 1100 and fit.samples == 1100
    for got, want in zip(fit.nuisance, ref):
        assert np.allclose(got, want, rtol=1e-8, atol=1e-10)


# --- the same run twice -------------------------------------------------------------------------

def test_the_same_log_twice_is_refused(tmp_path, held):
    a = log_from_columns(held[0], "a", delay_s=1e-3)
    b = log_from_columns(dict(held[0], t=held[0]["t"] + 100.0), "b", delay_s=1e-3)  # the same samples, other stamps
    with pytest.raises(ConfigError) as e:
        identify_plant([a, log_from_columns(held[1], "c", delay_s=1e-3), b])
    assert e.value.field == "b" and "the same samples as a (logs 1 and 3)" in e.value.reason
    pa = _csv(tmp_path / "a.csv", held[0])
    copy = tmp_path / "copy.csv"
    shutil.copy(pa, copy)
    out = tmp_path / "p.yaml"
    code, text = _run(pa, pa, "--delay-s", "0.001", "-o", out)
    assert code == 2 and text == f"exotune: error: {pa}: given twice (logs 1 and 2): identified together, one run " \
                                 "would count twice and shrink the standard errors by √2 without new data; give each " \
                                 "run once\n", text
    assert not out.exists()
    code, text = _run(pa, copy, "--delay-s", "0.001")
    assert code == 2 and text.startswith(f"exotune: error: {copy}: the same samples as {pa}"), text


def test_validation_on_a_fitting_log_is_refused(tmp_path, held):
    pa, pb = _csv(tmp_path / "a.csv", held[0]), _csv(tmp_path / "b.csv", held[1])
    copy = tmp_path / "copy.csv"
    shutil.copy(pb, copy)
    for v in (pa, copy):
        code, text = _run(pa, pb, "--delay-s", "0.001", "--validate", v)
        assert code == 2 and text.startswith(f"exotune: error: --validate: {v} holds the same samples as the fitting "
                                             "log") and "not held out" in text and text.count("\n") == 1, text
    code, text = _run(pa, "--delay-s", "0.001", "--validate", pb)
    assert code == 0 and f"held-out log {pb}" in text, text


# --- one parameter, two values ------------------------------------------------------------------

def test_one_parameter_fixed_to_two_values_is_refused(tmp_path, held):
    with pytest.raises(ConfigError) as e:
        parse_fix(["J_m=1", "motor_inertia=2"])
    assert e.value.field == "fix" and e.value.reason == ("motor_inertia is fixed twice, to 1 kg·m² (J_m=1) and to "
                                                         "2 kg·m² (motor_inertia=2): give it one value")
    with pytest.raises(ConfigError):
        parse_fix({"b_m": 17.9, "motor_damping": 18})
    assert parse_fix(["J_m=1", "motor_inertia=1.0"]) == {"motor_inertia": 1.0}  # the same value: no conflict
    code, text = _run(_csv(tmp_path / "a.csv", held[0]), "--fix", "J_m=1", "--fix", "motor_inertia=2")
    assert code == 2 and text.startswith("exotune: error: --fix: motor_inertia is fixed twice"), text


# --- messages -----------------------------------------------------------------------------------

@pytest.mark.parametrize("fh", [1e-300, 1e-320, 0.05])
def test_a_filter_corner_too_low_is_refused_in_a_short_line(held, fh):
    """Not a 300-digit sample count (nor an overflow for a subnormal corner): the corner is named
    with the lowest one that leaves enough samples, which then passes that check."""
    log = log_from_columns(held[0], delay_s=1e-3)
    with pytest.raises(ConfigError) as e:
        identify_plant(log, filter_hz=fh)
    assert e.value.field == "filter_hz" and len(str(e.value)) < 250, str(e.value)
    lowest = float(e.value.reason.split("a corner of ")[1].split(" Hz")[0])
    try:  # so low a corner may leave the plant unexcited, but not too few samples
        identify_plant(log, filter_hz=lowest)
    except ConfigError as again:
        assert "after the filter's transient" not in str(again), str(again)


def test_a_short_log_names_the_time_column():
    short = {k: v[:550] for k, v in held_logs(1, FS, 1.0, seed0=3)[0].items()}  # 80 samples of transient at 10 Hz
    with pytest.raises(ConfigError) as e:
        identify_plant(log_from_columns(short, delay_s=1e-3))
    assert e.value.field == "t"
    assert e.value.reason.startswith("550 samples leave 470 after the filter's transient (80 samples at 10 Hz)")


def test_reordered_or_repeated_stamps_are_named_as_such(held):
    t = held[0]["t"].copy()
    t[[100, 101]] = t[[101, 100]]  # two rows swapped: a double step, then a step back
    with pytest.raises(ConfigError) as e:
        log_from_columns(dict(held[0], t=t), delay_s=1e-3)
    assert e.value.field == "t" and e.value.reason == ("not increasing at sample 101 (step -0.001 s from sample 100): "
                                                       "the rows must be in time order")
    t = held[0]["t"].copy()
    t[50] = t[49]
    with pytest.raises(ConfigError) as e:
        log_from_columns(dict(held[0], t=t), delay_s=1e-3)
    assert e.value.reason == "not increasing at sample 50 (the time of sample 49 again): the rows must be in time order"
    t = np.r_[held[0]["t"][:300], held[0]["t"][301:]]
    with pytest.raises(ConfigError) as e:
        log_from_columns({k: (t if k == "t" else np.delete(v, 300)) for k, v in held[0].items()}, delay_s=1e-3)
    assert "missing after sample 299 (step 0.002 s, median 0.001 s)" in e.value.reason  # each number with its unit


def test_comment_lines_are_skipped(tmp_path, held):
    plain = read_log(_csv(tmp_path / "plain.csv", held[0]), delay_s=1e-3)
    above = read_log(_csv(tmp_path / "above.csv", held[0], "# rig 3, run 7\n#\n"), delay_s=1e-3)
    lines = (tmp_path / "plain.csv").read_text().splitlines(keepends=True)
    between = tmp_path / "between.csv"
    between.write_text("# notes\n" + "".join(lines[:50]) + "# marker, 0.049 s\n\n" + "".join(lines[50:]))
    for log in (above, read_log(between, delay_s=1e-3)):
        assert all(np.array_equal(log.signals[k], plain.signals[k]) for k in plain.signals)
    bad = tmp_path / "bad.csv"
    bad.write_text("# notes\n" + "".join(lines[:50]) + "# marker\n" + lines[50].replace(",", ",x", 1)
                   + "".join(lines[51:]))
    with pytest.raises(ConfigError) as e:
        read_log(bad)
    assert e.value.field == f"{bad}:53" and "is not a number" in e.value.reason  # the file's own line number
    headless = tmp_path / "headless.csv"
    headless.write_text("".join(lines[1:]))
    with pytest.raises(ConfigError) as e:
        read_log(headless)
    assert e.value.field == f"{headless}:1" and e.value.reason.startswith("a row of numbers, not a header")


def test_a_fixed_value_is_read_as_a_design_file_reads_numbers():
    """`--fix J_m=1_000` went through float(), which reads 1000; a design file (YAML 1.2) and the
    other number options refuse '1_000'."""
    from exotune.errors import ConfigError
    from exotune.identification.estimate import parse_fix

    assert parse_fix(["J_m=0.44", "B_m= 1e1"]) == {"motor_inertia": 0.44, "motor_damping": 10.0}
    with pytest.raises(ConfigError, match="must be a number"):
        parse_fix(["J_m=1_000"])
    with pytest.raises(ConfigError, match="finite"):
        parse_fix(["J_m=inf"])
