"""exotune.identification.signals: the filtered signals of one or several logs (each filtered on
its own from the zero state, the transient dropped, a held command delayed within its log) and
the filters' start-up transients."""

import math

import numpy as np
import pytest

from exotune.identification.data import log_from_columns
from exotune.identification.filters import held_svf, svf_order
from exotune.identification.signals import TRANSIENT_END, FilteredLogs, transient_modes

FS, FH = 1000.0, 20.0


def test_transient_modes_by_their_formula():
    M = transient_modes(10, 5000, FS, FH)
    w = 2 * math.pi * FH / FS
    K = int(math.floor(TRANSIENT_END / w)) + 1 - 10
    assert M.shape == (3, K)
    wt = w * np.arange(10, 10 + K)
    assert np.allclose(M, [np.exp(-wt), wt * np.exp(-wt), wt**2 * np.exp(-wt)], rtol=1e-14)
    assert M[2, -1] < 1e-20
    assert transient_modes(10, 50, FS, FH).shape == (3, 40)  # a short log: every kept sample
    assert transient_modes(60, 50, FS, FH).shape == (3, 0)


def _log(n, seed, held=False):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    c = {"t": t, "theta_m": np.sin(3 * t) + 0.01 * rng.normal(size=n), "tau_s": rng.normal(size=n),
         "theta_j": np.cos(2 * t), "tau_c": rng.normal(size=n)}
    c["tau_cmd" if held else "tau_m"] = rng.normal(size=n)
    return log_from_columns(c, source=f"log{seed}", delay_s="0.002" if held else "0")


def test_each_log_is_filtered_on_its_own_and_the_transient_dropped():
    logs = [_log(600, 1), _log(900, 2)]
    sig = FilteredLogs(logs, FH, [50, 80])
    assert sig.samples == 550 + 820 and not sig.held
    a, b = sig.get("theta_m", 2)
    assert a.size == 550 and b.size == 820
    assert np.allclose(a, svf_order(logs[0].signals["theta_m"], FS, FH, 2)[50:], rtol=1e-8, atol=1e-9)
    assert np.allclose(b, svf_order(logs[1].signals["theta_m"], FS, FH, 2)[80:], rtol=1e-8, atol=1e-9)  # from the zero state
    sea = sig.get("sea_x")[0]
    assert np.allclose(sea, svf_order(logs[0].signals["theta_j"] - logs[0].signals["theta_m"], FS, FH, 0)[50:],
                       rtol=1e-8, atol=1e-12)
    assert np.array_equal(sig.applied(0)[1], sig.get("tau_m")[1])
    assert [m.shape[1] for m in sig.modes()] == [transient_modes(50, 600, FS, FH).shape[1],
                                                 transient_modes(80, 900, FS, FH).shape[1]]
    sig.drop("theta_m")
    assert np.array_equal(sig.get("theta_m", 2)[0], a)  # recomputed: the same


def test_a_held_command_is_delayed_within_its_log():
    logs = [_log(600, 3, held=True), _log(700, 4, held=True)]
    sig = FilteredLogs(logs, FH, [50, 50])
    assert sig.held
    for i, log in enumerate(logs):
        h = held_svf(log.signals["tau_cmd"], log.sample_rate_hz, FH)
        assert np.array_equal(sig.command(i), h)
        applied = sig.applied(2)[i]
        assert applied.size == log.samples - 50
        assert np.array_equal(applied, h[48: log.samples - 2])  # applied 2 samples after it is logged


def test_overflowing_values_name_the_column():
    """The loader refuses signals beyond ±1e9 (tests/identification/test_data.py); a log built
    around it still gets a named error from the filter, not an overflow warning."""
    import dataclasses

    log = _log(600, 5)
    big = dict(log.signals)
    big["theta_m"] = big["theta_m"] * 1e306
    from exotune.errors import ConfigError

    with pytest.raises(ConfigError) as ei:
        log_from_columns(big)
    assert ei.value.field == "theta_m" and "beyond" in ei.value.reason
    sig = FilteredLogs([dataclasses.replace(log, signals=big)], FH, [50])
    with pytest.raises(ConfigError) as ei:
        sig.get("theta_m", 2)
    assert ei.value.field == "theta_m" and "overflow" in ei.value.reason
