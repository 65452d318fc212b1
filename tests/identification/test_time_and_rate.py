"""Time and rate (issue 26, item 2): epoch time stamps and µs jitter are judged relative to the
step, dropped samples are found at any t, and the sample rate can be given instead."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from exotune.api import identify
from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.identification import identify_plant, log_from_columns, read_log
from identification.simulated_logs import TRUE, held_logs, smooth_logs

EPOCH = 1.7e9


@pytest.fixture(scope="module")
def held10k():
    return held_logs(1, 10000.0, 1.0, noise=False)[0]


def _csv(path, cols, t_text=None):
    names = list(cols)
    rows = []
    for i in range(len(cols[names[0]])):
        rows.append(",".join(t_text[i] if (n == "t" and t_text is not None) else repr(float(cols[n][i])) for n in names))
    path.write_text(",".join(names) + "\n" + "\n".join(rows) + "\n")
    return path


def test_epoch_time_stamps_give_the_rate_and_the_plant(held10k, tmp_path):
    n = held10k["t"].size
    # as float64 (the library): t − t[0] is exact, the rate from the mean step
    cols = dict(held10k, t=EPOCH + np.arange(n) / 1e4)
    log = log_from_columns(cols, delay_s=1e-4)
    assert log.sample_rate_hz == pytest.approx(1e4, rel=1e-6) and log.delay_samples == 1  # float64 stamps: ulp 2.4e-7 s
    r = identify_plant(log)
    assert r["motor_inertia"].value == pytest.approx(TRUE["motor_inertia"], rel=1e-6)
    # as decimal text (the CSV reader): subtracted in decimal, µs kept
    text = [f"{1700000000 + i // 10000}.{i % 10000:04d}00" for i in range(n)]
    log = read_log(_csv(tmp_path / "epoch.csv", cols, text), delay_s=1e-4)
    assert log.sample_rate_hz == pytest.approx(1e4, rel=1e-12) and log.delay_samples == 1


def test_microsecond_jitter_is_tolerated(held10k):
    rng = np.random.default_rng(3)
    n = held10k["t"].size
    t = EPOCH + np.arange(n) / 1e4 + rng.uniform(-2e-6, 2e-6, n)  # ±2 µs at 10 kHz: ±2 % of the step
    log = log_from_columns(dict(held10k, t=t), delay_s=1e-4)
    assert log.sample_rate_hz == pytest.approx(1e4, rel=1e-6) and log.delay_samples == 1
    r = identify_plant(log)
    assert r["sea_stiffness"].value == pytest.approx(TRUE["sea_stiffness"], rel=1e-6)


@pytest.mark.parametrize("t0", [0.0, 1e3, EPOCH])
@pytest.mark.parametrize("where", [5, 2000, 9990])
def test_a_dropped_sample_is_found_at_any_t(held10k, t0, where):
    cols = {k: np.delete(v, where) for k, v in dict(held10k, t=t0 + np.arange(held10k["t"].size) / 1e4).items()}
    with pytest.raises(ConfigError) as e:
        log_from_columns(cols, delay_s=1e-4)
    assert e.value.field == "t" and "1 sample(s) missing" in str(e.value), str(e.value)


def test_repeated_or_reversed_stamps_are_refused(held10k):
    t = np.arange(held10k["t"].size) / 1e4
    for bad in (np.r_[t[:100], t[99], t[101:]], np.r_[t[:100], t[101], t[100], t[102:]]):
        with pytest.raises(ConfigError) as e:
            log_from_columns(dict(held10k, t=bad), delay_s=1e-4)
        assert e.value.field == "t"


def test_sample_rate_overrides_the_time_column(tmp_path):
    cols = smooth_logs(1, 1000.0, 4.0, noise=False)[0]
    ref = identify(cols)
    no_t = {k: v for k, v in cols.items() if k != "t"}
    r = identify(no_t, sample_rate_hz=1000.0)
    assert r.sample_rate_hz == 1000.0 and r.rate_source == "given"
    assert r["motor_inertia"].value == pytest.approx(ref["motor_inertia"].value, rel=1e-12)
    with pytest.raises(ConfigError) as e:
        identify(no_t)
    assert e.value.field == "t"
    # a time column in milliseconds: wrong rate from t, right with the option
    ms = dict(cols, t=cols["t"] * 1000)
    log = _csv(tmp_path / "ms.csv", ms)
    res = CliRunner().invoke(cli, ["identify", str(log), "--sample-rate-hz", "1000"])
    assert res.exit_code == 0, res.output
    assert "at 1000 Hz (given)" in res.output and "motor_inertia (J_m): 0.44" in res.output
    for bad in ("0", "-5", "x", "nan"):
        res = CliRunner().invoke(cli, ["identify", str(log), "--sample-rate-hz", bad])
        assert res.exit_code == 2 and res.output.startswith("exotune: error: --sample-rate-hz"), res.output
