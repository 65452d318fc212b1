"""exotune.identification.frf: the non-parametric frequency responses of a simulated log against
the plant's transfer functions, the applied torque, the Welch segment and a periodic command's period."""

import numpy as np
import pytest

from exotune.identification.data import log_from_columns
from exotune.identification.estimate import identify_plant
from exotune.identification.frf import (AVERAGES, MIN_SEGMENT, applied_torque, command_period, frequency_responses,
                                        segment_length)

from identification.simulated_logs import TRUE, held_logs

FS = 1000.0


@pytest.fixture(scope="module")
def responses():
    log = log_from_columns(held_logs(1, FS, 20.0, delay=1)[0], delay_s="0.001")
    return log, frequency_responses(log, identify_plant(log))


def test_the_four_transfer_functions_match_the_plant(responses):
    _log, frs = responses
    assert [fr.name for fr in frs] == ["motor", "spring", "joint", "cuff"]
    Jm, Bm, Ks, Jj, Kc = (TRUE[k] for k in ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia",
                                             "cuff_stiffness"))
    truth = {"motor": lambda s: 1 / (Jm * s**2 + Bm * s), "spring": lambda s: Ks + 0 * s,
             "joint": lambda s: 1 / (Jj * s**2), "cuff": lambda s: Kc + 0 * s}
    for fr in frs:
        ok = fr.coherent & (fr.frequency_hz > 0.5) & (fr.frequency_hz < 40.0)
        assert ok.sum() >= 5, fr.name
        s = 2j * np.pi * fr.frequency_hz[ok]
        ref = truth[fr.name](s)
        rel = np.abs(fr.measured[ok] / ref - 1)
        # the estimate's own random error describes its scatter: few bins beyond 3σ (+ 1 %)
        assert np.median(rel) < 0.05, fr.name
        assert np.mean(rel > 3 * fr.relative_error[ok] + 0.01) <= 0.1, (fr.name, rel.max())
        assert np.allclose(fr.model[ok], ref, rtol=1e-3)  # the model: the identified parameters
        assert fr.frequency_hz.max() <= FS / 4
    local = {p.key: p for p in frs[0].local}
    assert set(local) == {"motor_inertia", "motor_damping"}
    assert local["motor_inertia"].estimate == pytest.approx(TRUE["motor_inertia"], rel=0.02)


def test_applied_torque_delays_the_command():
    t = np.arange(300) / FS
    cmd = np.arange(300.0)
    log = log_from_columns({"t": t, "theta_m": np.sin(t), "tau_s": t, "tau_cmd": cmd}, delay_s="0.003")
    z = applied_torque(log, 3)
    assert z[:3].tolist() == [0.0, 0.0, 0.0] and z[3:6].tolist() == [0.0, 1.0, 2.0] and z.size == 300
    assert np.array_equal(applied_torque(log, 0), cmd)
    log_m = log_from_columns({"t": t, "theta_m": np.sin(t), "tau_s": t, "tau_m": cmd})
    assert np.array_equal(applied_torque(log_m, 5), cmd)  # an applied torque is not delayed


def test_segment_length():
    assert segment_length(100) == MIN_SEGMENT
    assert segment_length(20000) == 2048  # the largest power of two with 8 segments: 20000/8 = 2500
    for n in (5000, 65536, 100003):
        L = segment_length(n)
        assert L & (L - 1) == 0 and n // L >= AVERAGES and n // (2 * L) < AVERAGES


def test_command_period():
    x = np.tile(np.sin(np.arange(50) * 0.3) + np.arange(50) * 1e-3, 6)
    assert command_period(x) == 50
    assert command_period(np.r_[np.zeros(7), x], start=7) == 50
    assert command_period(np.random.default_rng(0).normal(size=300)) is None
    assert command_period(np.ones(5)) is None
