"""exotune.analysis.dob: the margins of the DOB loop L = Q e^{−sT}/(1 − Q) against python-control's
``stability_margins`` on the same loop (the rational loop exactly for T = 0; with a delay the
crossover is unchanged and the phase margin shifts by ω_c T, the gain margin is checked against
python-control on the exact frequency response), the closed-form path for the standard Q against the
general path, and the delay margin against the closed loop's exact verdict."""

from __future__ import annotations

import control
import numpy as np
import pytest

from exotune.analysis.dob import dob_margins, dob_margins_rows

WQ = np.array([30.0, 100.0, 400.0, 60.0])
ZETA = np.array([0.5, 0.7, 1.0, 1.5])


def _standard(T):
    nq = (WQ**2)[:, None]
    dq = np.stack([WQ**2, 2 * ZETA * WQ, np.ones(WQ.size)], axis=1)
    return nq, dq, np.broadcast_to(np.asarray(T, float), WQ.shape).copy()


def _loop(nq, dq):
    num, den = np.trim_zeros(nq[::-1], "f"), np.polysub(dq[::-1], np.pad(nq, (0, dq.size - nq.size))[::-1])
    return control.tf(num, np.trim_zeros(den, "f"))


def test_without_delay_the_margins_are_python_controls():
    nq, dq, T = _standard(0.0)
    got = dob_margins_rows(nq, dq, T)
    for i in range(WQ.size):
        gm, pm, sm, wpc, wgc, wms = control.stability_margins(_loop(nq[i], dq[i]), returnall=False)
        assert got.phase_margin_deg[i] == pytest.approx(pm, rel=1e-6)
        assert got.crossover_hz[i] * 2 * np.pi == pytest.approx(wgc, rel=1e-6)
        assert np.isinf(got.gain_margin_db[i]) and np.isinf(gm)
        assert got.stable[i]
        assert got.delay_margin_s[i] == pytest.approx(np.radians(pm) / wgc, rel=1e-6)


@pytest.mark.parametrize("T", [2e-4, 3e-3])
def test_with_a_delay_the_margins_are_python_controls_on_the_exact_response(T):
    nq, dq, Tv = _standard(T)
    got = dob_margins_rows(nq, dq, Tv)
    for i in range(WQ.size):
        L = _loop(nq[i], dq[i])
        _, pm0, _, _, wgc, _ = control.stability_margins(L, returnall=False)
        assert got.crossover_hz[i] * 2 * np.pi == pytest.approx(wgc, rel=1e-6)
        pm = (pm0 - np.degrees(wgc * T) + 180.0) % 360.0 - 180.0
        assert got.phase_margin_deg[i] == pytest.approx(pm, rel=1e-6, abs=1e-6)
        w = np.geomspace(1e-2 * WQ[i], 4e2 / T, 3000)
        frd = control.frd(np.squeeze(L(1j * w)) * np.exp(-1j * w * T), w)
        gm, _, _, wpc, _, _ = control.stability_margins(frd, returnall=False)
        assert got.gain_margin_db[i] == pytest.approx(20 * np.log10(gm), abs=0.02)
        assert got.stable[i] == (pm > 0)


def test_the_general_path_equals_the_standard_closed_form():
    """Q written with a trailing zero coefficient leaves the closed form: the same margins."""
    nq, dq, T = _standard(1.5e-3)
    ref = dob_margins_rows(nq, dq, T)
    got = dob_margins_rows(np.pad(nq, ((0, 0), (0, 1))), dq, T)
    for f in ("phase_margin_deg", "gain_margin_db", "delay_margin_s", "crossover_hz"):
        np.testing.assert_allclose(getattr(got, f), getattr(ref, f), rtol=1e-7, err_msg=f)
    np.testing.assert_array_equal(got.stable, ref.stable)


def test_a_third_order_q_against_python_control():
    """A non-standard Q (third order, binomial): every crossover considered."""
    wq = 80.0
    nq = np.array([[wq**3]])
    dq = np.array([[wq**3, 3 * wq**2, 3 * wq, 1.0]])
    T = np.array([5e-4])
    got = dob_margins_rows(nq, dq, T)
    L = _loop(nq[0], dq[0])
    _, pm0, _, _, wgc, _ = control.stability_margins(L, returnall=False)
    assert got.crossover_hz[0] * 2 * np.pi == pytest.approx(wgc, rel=1e-6)
    assert got.phase_margin_deg[0] == pytest.approx(pm0 - np.degrees(wgc * T[0]), rel=1e-6)
    w = np.geomspace(1.0, 4e2 / T[0], 3000)
    gm, *_ = control.stability_margins(control.frd(np.squeeze(L(1j * w)) * np.exp(-1j * w * T[0]), w), returnall=False)
    assert got.gain_margin_db[0] == pytest.approx(20 * np.log10(gm), abs=0.02)


def test_delay_margin_is_where_the_closed_loop_loses_stability():
    nq, dq, T = _standard(5e-4)
    dm = dob_margins_rows(nq, dq, T).delay_margin_s
    assert (dm > 0).all()
    below = dob_margins_rows(nq, dq, T + 0.97 * dm)
    above = dob_margins_rows(nq, dq, T + 1.03 * dm)
    assert below.stable.all() and not above.stable.any()
    np.testing.assert_array_equal(above.delay_margin_s, 0.0)  # no delay tolerated when unstable


def test_no_dob_gives_none_and_repeated_rows_are_computed_once():
    class _CS:  # the two fields dob_margins reads
        dob_q = None
        delay_s = 1e-3

    assert dob_margins(_CS(), 3) is None

    class _Q:
        num = np.array([[900.0], [900.0], [1e4]])
        den = np.array([[900.0, 30.0, 1.0], [900.0, 30.0, 1.0], [1e4, 140.0, 1.0]])

    class _CS2:
        dob_q = _Q()
        delay_s = np.array([1e-3, 1e-3, 1e-3])

    got = dob_margins(_CS2(), 3)
    ref = dob_margins_rows(_Q.num, _Q.den, _CS2.delay_s)
    np.testing.assert_allclose(got.delay_margin_s, ref.delay_margin_s, rtol=1e-12)
    assert got.delay_margin_s[0] == got.delay_margin_s[1] != got.delay_margin_s[2]
