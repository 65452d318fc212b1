"""exotune.analysis.dob at extreme Q filters and delays (ζ ∈ [1e-4, 1e4], f_q ∈ [1e-3, 1e5] Hz,
T ∈ [0, 0.1] s) against references written here: the crossover of
L = ω_q² e^{−sT}/(s (s + 2ζω_q)) solved from |L(jω)| = 1 with mpmath at 50 digits, the phase
analytically, the closed loop's stability from an argument-principle count of the roots of
s (s + a) + ω_q² e^{−sT} on a dense grid, and python-control's margins on the exact frequency
response and on a high-order Padé closed loop.

Found: the crossover ω_q √(√(4ζ⁴ + 1) − 2ζ²) cancelled at large ζ (f_q = 1 mHz, ζ = 1000:
5.0006e-7 Hz, delay margin 499 940 s against 5e-7 Hz and 499 999.92 s; ζ = 1e4: crossover 0,
delay margin inf), and the phase margin was wrapped into (−180°, 180°] so that an unstable loop
read as healthy (100 Hz, ζ = 0.7, T = 14.37 ms: +89.8° for a continuous −270.2°)."""

from __future__ import annotations

import control
import mpmath as mp
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from exotune.analysis.dob import dob_margins_rows

mp.mp.dps = 50


def _rows(fq, zeta, T):
    fq, zeta, T = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float)) for v in (fq, zeta, T)))
    wq = 2 * np.pi * fq
    nq = (wq * wq)[:, None]
    dq = np.stack([wq * wq, 2 * zeta * wq, np.ones_like(wq)], axis=1)
    return nq, dq, T.copy()


def _margins(fq, zeta, T):
    return dob_margins_rows(*_rows(fq, zeta, T))


def _ref(fq, zeta):
    """(ω_c [rad/s], PM at T = 0 [rad], critical delay [s]) in mpmath: ω_c the root of
    log|L(jω)| = log ω_q² − log ω − ½ log(ω² + a²) (monotone), the phase analytically."""
    wq = 2 * mp.pi * mp.mpf(fq)
    a = 2 * mp.mpf(zeta) * wq

    def f(lw):
        w = mp.e**lw
        return 2 * mp.log(wq) - lw - mp.log(w * w + a * a) / 2

    lo, hi = mp.log(wq) - mp.log(2 * mp.mpf(zeta) + 1) - 1, mp.log(wq) + 1  # f(lo) > 0 > f(hi)
    wc = mp.e ** mp.findroot(f, (lo, hi), solver="anderson")
    pm0 = mp.pi - (mp.pi / 2 + mp.atan2(wc, a))  # 180° + ∠L(jω_c) with ∠ = −90° − atan(ω/a) at T = 0
    return wc, pm0, pm0 / wc


def _rhp_roots(fq, zeta, T):
    """Roots of χ(s) = s (s + a) + ω_q² e^{−sT} in Re s > 0, by the argument principle in the scaled
    variable σ = s/ω_q: Z = 1 − Δ_{0→∞} arg χ(jσ)/π (χ ~ s² at infinity). Beyond the crossover σ_c
    (|σ (σ + 2ζ)| = 1 there) χ = p (1 + w) with |w| < 1, so the tail is exact: Δ arg p =
    atan(2ζ/σ_c), Δ arg (1 + w) = −arg(1 + w(σ_c)); the dense grid covers [0, σ_c]."""
    wq = 2 * np.pi * fq
    tau = wq * T
    z = zeta
    sc = 1.0 / np.sqrt(np.hypot(2 * z * z, 1.0) + 2 * z * z)
    n = int(max(4000, 200 * sc * tau))
    s = np.linspace(0.0, sc, n)
    chi = 1j * s * (1j * s + 2 * z) + np.exp(-1j * s * tau)
    d = np.unwrap(np.angle(chi))
    delta = d[-1] - d[0]
    w_c = np.exp(-1j * sc * tau) / (1j * sc * (1j * sc + 2 * z))
    delta += np.arctan2(2 * z, sc) - np.angle(1 + w_c)
    Z = 1 - delta / np.pi
    assert abs(Z - round(Z)) < 0.05, Z
    return int(round(Z))


@pytest.mark.parametrize("fq,zeta,T", [(1e-3, 1e3, 1e-3), (1e-3, 1e4, 0.1), (1e5, 1e4, 0.0), (1e5, 1e-4, 0.0),
                                       (1e-3, 1e-4, 0.05), (1e5, 1.0, 1e-7), (10.0, 0.7, 1e-3)])
def test_extreme_filters_against_mpmath(fq, zeta, T):
    """The reproducer (dob cutoff 1 mHz, damping 1000, T = 1 ms) and the corners of the range."""
    got = _margins(fq, zeta, T)
    wc, pm0, tcrit = _ref(fq, zeta)
    assert got.crossover_hz[0] == pytest.approx(float(wc / (2 * mp.pi)), rel=1e-12)
    stable = T < tcrit
    assert bool(got.stable[0]) == stable
    pm = pm0 - wc * T
    if stable:
        assert got.phase_margin_deg[0] == pytest.approx(float(mp.degrees(pm)), rel=1e-10)
        assert got.delay_margin_s[0] == pytest.approx(float(pm / wc), rel=1e-10)
        assert got.gain_margin_db[0] > 0
    else:
        assert got.phase_margin_deg[0] == pytest.approx(max(-180.0, float(mp.degrees(pm))), rel=1e-10)
        assert got.delay_margin_s[0] == 0.0 and got.gain_margin_db[0] < 0


def test_reproducer_values():
    """f_q = 1 mHz, ζ = 1000, T = 1 ms: ω_c = ω_q/2000 to 1e-13, delay margin 499 999.919 s."""
    got = _margins(1e-3, 1e3, 1e-3)
    assert got.crossover_hz[0] == pytest.approx(5e-7, rel=1e-12)
    assert got.delay_margin_s[0] == pytest.approx(499999.9194225441, rel=1e-12)


@pytest.mark.parametrize("fq,zeta,T,pm_cont", [
    (100.0, 0.7, 0.01437, -270.16229387),  # wrapped: +89.84° (was reported so)
    (100.0, 0.7, 0.02, -401.53628202),  # wrapped: −41.5°
    (100.0, 0.7, 0.004, -28.182142),  # −180° < PM < 0: the continuous value itself
    (1e5, 1e-4, 0.1, None),  # wrapped: +0.047° (was reported so) for a lag of 2.3e6°
])
def test_unstable_loops_never_read_as_a_positive_phase_margin(fq, zeta, T, pm_cont):
    got = _margins(fq, zeta, T)
    wc, pm0, tcrit = _ref(fq, zeta)
    pm = float(mp.degrees(pm0 - wc * T))
    if pm_cont is not None:
        assert pm == pytest.approx(pm_cont, rel=1e-4)
    assert T > tcrit
    if wc * T < 50:  # the argument-principle grid is affordable
        assert _rhp_roots(fq, zeta, T) > 0
    assert not got.stable[0]
    assert got.phase_margin_deg[0] == pytest.approx(max(pm, -180.0), rel=1e-10)
    assert got.gain_margin_db[0] <= 0 and got.delay_margin_s[0] == 0.0
    # the general (root-based) path of a Q written with a trailing zero agrees
    nq, dq, Tv = _rows(fq, zeta, T)
    gen = dob_margins_rows(np.pad(nq, ((0, 0), (0, 1))), dq, Tv)
    assert not gen.stable[0] and gen.phase_margin_deg[0] == pytest.approx(got.phase_margin_deg[0], rel=1e-6)


def _logu(lo, hi):
    return st.floats(np.log10(lo), np.log10(hi)).map(lambda e: 10.0**e)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(fq=_logu(1e-3, 1e5), zeta=_logu(1e-4, 1e4), T=st.one_of(st.just(0.0), st.floats(0.0, 0.1), _logu(1e-9, 0.1)))
def test_delay_margin_is_pm_over_crossover_and_stability_is_t_below_it(fq, zeta, T):
    """Property: delay margin = PM [rad]/ω_c (extra delay), the loop is stable iff T is below the
    critical delay PM(T = 0)/ω_c of the mpmath crossover, and the closed loop's right-half-plane
    root count (argument principle, where the grid is affordable) says the same."""
    wc, pm0, tcrit = _ref(fq, zeta)
    tcrit = float(tcrit)
    assume(abs(T - tcrit) > 1e-8 * tcrit)
    got = _margins(fq, zeta, T)
    assert got.crossover_hz[0] == pytest.approx(float(wc / (2 * mp.pi)), rel=1e-12)
    stable = T < tcrit
    assert bool(got.stable[0]) == stable
    if float(wc) * T < 60:
        assert (_rhp_roots(fq, zeta, T) == 0) == stable
    pm = float(pm0 - wc * T)
    if stable:
        assert got.phase_margin_deg[0] == pytest.approx(np.degrees(pm), rel=1e-9, abs=1e-12)
        dm = np.radians(got.phase_margin_deg[0]) / (2 * np.pi * got.crossover_hz[0])
        assert got.delay_margin_s[0] == pytest.approx(dm, rel=1e-9)
        assert got.delay_margin_s[0] == pytest.approx(tcrit - T, rel=1e-9, abs=1e-9 * tcrit)
        assert got.gain_margin_db[0] > 0
    else:
        assert -180.0 <= got.phase_margin_deg[0] <= 0.0
        assert got.phase_margin_deg[0] == pytest.approx(max(np.degrees(pm), -180.0), rel=1e-9)
        assert got.delay_margin_s[0] == 0.0 and got.gain_margin_db[0] <= 0.0


@pytest.mark.parametrize("fq,zeta", [(5.0, 0.3), (30.0, 0.7), (60.0, 2.0), (200.0, 0.05)])
def test_moderate_delays_against_python_control(fq, zeta):
    """python-control's margins on the exact frequency response (wrapped PM, GM) and the closed-loop
    poles with a 12th-order Padé delay, at delays 0.5 and 1.5 times (and 3.5 times) the critical one."""
    wq, a = 2 * np.pi * fq, 4 * np.pi * fq * zeta
    L0 = control.tf([wq * wq], [1.0, a, 0.0])
    _, _, tcrit = _ref(fq, zeta)
    for k in (0.5, 1.5, 3.5):
        T = k * float(tcrit)
        got = _margins(fq, zeta, T)
        wc = 2 * np.pi * got.crossover_hz[0]
        w = np.geomspace(1e-3 * min(wc, a), 50 * max(wq, 1 / T), 4000)
        frd = control.frd(np.squeeze(L0(1j * w)) * np.exp(-1j * w * T), w)
        gms, pms, _, _, wgcs, _ = control.stability_margins(frd, returnall=True)
        (pm,), (wgc,) = pms, wgcs  # one gain crossover
        assert wc == pytest.approx(wgc, rel=1e-4)
        # the smallest over every phase crossover (python-control's single value picks another one
        # when the loop is unstable)
        assert got.gain_margin_db[0] == pytest.approx(np.min(20 * np.log10(gms)), abs=0.05)
        if k < 1:
            assert got.stable[0] and got.phase_margin_deg[0] == pytest.approx(pm, rel=1e-3)
        else:
            # python-control wraps; the continuous PM differs by a multiple of 360°, and is ≤ 0
            assert not got.stable[0] and got.phase_margin_deg[0] <= 0
            cont = got.phase_margin_deg[0]
            if cont > -180:
                d = (cont - pm) % 360
                assert min(d, 360 - d) < 1e-2
        if wc * T < 3:  # where a 12th-order Padé is accurate
            num, den = control.pade(T, 12)
            cl = control.feedback(L0 * control.tf(num, den), 1)
            assert (np.max(np.real(cl.poles())) < 0) == bool(got.stable[0])


def test_the_reproducer_design_through_analyze_batch():
    """The reproducer's design (examples/paper.yaml with dob cutoff 1 mHz, damping 1000) and a
    long-delay row: the batch analysis's DOB columns carry the same values as the references."""
    import copy
    from pathlib import Path

    from exotune.analysis import analyze_batch
    from exotune.config import batch_config, design_from_mapping, load_design

    raw = copy.deepcopy(load_design(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml").raw)
    raw["implementation"]["dob"] = {"cutoff_hz": 1e-3, "damping": 1000.0}
    raw["implementation"]["delay_s"] = 1e-3
    raw["humans"], raw["environment"] = [], []
    cfg = batch_config(design_from_mapping(raw), {"implementation.dob.cutoff_hz": np.array([1e-3, 100.0]),
                                                  "implementation.dob.damping": np.array([1000.0, 0.7]),
                                                  "implementation.delay_s": np.array([1e-3, 0.01437])})
    res = analyze_batch(cfg)
    assert res.column("dob_crossover_hz")[0] == pytest.approx(5e-7, rel=1e-12)
    assert res.column("dob_delay_margin_s")[0] == pytest.approx(499999.9194225441, rel=1e-12)
    assert bool(res.column("dob_stable")[0]) and not bool(res.column("dob_stable")[1])
    assert res.column("dob_phase_margin_deg")[1] == -180.0  # a continuous −270.2°, once reported +89.8°
