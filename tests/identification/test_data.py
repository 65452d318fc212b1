"""exotune.identification.data: measured logs (CSV and columns) checked column by column, each
error naming the column or option."""

import numpy as np
import pytest

from exotune.errors import ConfigError
from exotune.identification.data import COLUMNS, MIN_SAMPLES, MeasuredLog, log_from_columns, read_log

N = 400
FS = 1000.0


def _cols(**kw):
    t = np.arange(N) / FS
    c = {"t": t, "theta_m": np.sin(t), "tau_s": np.cos(t), "tau_m": 0.5 * t}
    c.update(kw)
    return {k: v for k, v in c.items() if v is not None}


def test_a_good_log():
    log = log_from_columns(_cols(t=1.7e9 + np.arange(N) / FS), source="x.csv")  # epoch stamps
    assert isinstance(log, MeasuredLog) and log.samples == N and not log.tau_m_held
    assert log.sample_rate_hz == pytest.approx(FS, rel=1e-6) and log.rate_source == "t"
    assert log.signals["t"][0] == 0.0 and log.delay_samples == 0 and log.source == "x.csv"


def test_given_rate_and_command_delay():
    log = log_from_columns(_cols(t=None, tau_m=None, tau_cmd=np.zeros(N)), delay_s="0.002", sample_rate_hz=FS)
    assert log.rate_source == "given" and log.tau_m_held and log.delay_samples == 2
    assert log.signals["t"][:3].tolist() == [0.0, 0.001, 0.002]
    auto = log_from_columns(_cols(tau_m=None, tau_cmd=np.zeros(N)), delay_s="auto")
    assert auto.delay_samples is None


@pytest.mark.parametrize("cols, kw, field, reason", [
    (_cols(speed=np.zeros(N)), {}, "speed", "unknown column"),
    (_cols(tau_s=None), {}, "tau_s", "missing column (SEA spring torque [N·m])"),
    (_cols(t=None), {}, "t", "missing column"),
    (_cols(tau_cmd=np.zeros(N)), {}, "tau_m", "exactly one of tau_m"),
    (_cols(tau_m=None), {}, "tau_m", "exactly one of tau_m"),
    (_cols(theta_m=["a"] * N), {}, "theta_m", "not a column of numbers"),
    (_cols(tau_s=np.r_[np.zeros(N - 1), np.nan]), {}, "tau_s", f"sample {N - 1} is nan"),
    # a value no joint produces (a wrong unit, corrupt data) would overflow the sums of squares
    (_cols(theta_m=np.r_[np.zeros(7), 1e300, np.zeros(N - 8)]), {}, "theta_m",
     "sample 7 is 1e+300 rad: beyond ±1e+09 rad, not a measured motor angle"),
    (_cols(tau_m=np.r_[-2e9, np.zeros(N - 1)]), {}, "tau_m", "sample 0 is -2e+09 N·m: beyond ±1e+09 N·m"),
    (_cols(tau_s=np.zeros(N - 1)), {}, "t", "different lengths"),
    ({k: v[:MIN_SAMPLES - 1] for k, v in _cols().items()}, {}, "t", f"{MIN_SAMPLES - 1} samples: at least"),
    (_cols(t=np.r_[np.arange(100), np.arange(101, N + 1)] / FS), {}, "t", "about 1 sample(s) missing after sample 99"),
    (_cols(t=np.r_[np.arange(200), np.arange(199, -1, -1)] / FS), {}, "t", "not increasing"),
    (_cols(), {"sample_rate_hz": -1.0}, "sample_rate_hz", "must be > 0, got -1.0"),
    (_cols(tau_m=None, tau_cmd=np.zeros(N)), {"delay_s": "0.0015"}, "delay_s", "1.5 samples at 1000 Hz"),
    (_cols(), {"delay_s": "auto"}, "delay_s", "this log has tau_m"),
    (_cols(), {"delay_s": "soon"}, "delay_s", "neither a delay [s] nor auto"),
    (_cols(), {"delay_s": -1}, "delay_s", "is not a delay ≥ 0 s"),
    (_cols(tau_m=None, tau_cmd=np.zeros(N)), {"delay_s": True}, "delay_s", "True is neither a delay [s] nor auto"),
    (_cols(), {"delay_s": 10 ** 400}, "delay_s", "neither a delay [s] nor auto"),
])
def test_bad_logs_name_the_column(cols, kw, field, reason):
    with pytest.raises(ConfigError) as ei:
        log_from_columns(cols, **kw)
    assert ei.value.field == field and reason in ei.value.reason


def test_read_log_csv_round_trip(tmp_path):
    c = _cols(theta_j=np.full(N, 0.25))
    p = tmp_path / "log.csv"
    names = list(c)
    rows = [",".join(names)] + [",".join(repr(float(c[k][i])) for k in names) for i in range(N)]
    p.write_text("\n".join(rows) + "\n")
    log = read_log(p)
    for k in names:
        assert np.allclose(log.signals[k], c[k], rtol=0, atol=1e-15), k
    assert log.sample_rate_hz == pytest.approx(FS) and log.source == str(p)
    assert set(COLUMNS) >= set(log.signals)
    bad = tmp_path / "bad.csv"
    bad.write_text("t,theta_m,tau_s,tau_m\n0,1,2\n")
    with pytest.raises(ConfigError) as ei:
        read_log(bad)
    assert str(bad) in str(ei.value)


def test_the_largest_accepted_signal_passes():
    """±MAX_SIGNAL itself is accepted (and the time column has no such bound: epoch stamps)."""
    from exotune.identification.data import MAX_SIGNAL

    log = log_from_columns(_cols(theta_m=np.r_[MAX_SIGNAL, -MAX_SIGNAL, np.zeros(N - 2)], t=1.7e9 + np.arange(N) / FS))
    assert log.signals["theta_m"][0] == MAX_SIGNAL
