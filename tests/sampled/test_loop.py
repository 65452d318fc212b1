"""Sampled-data model (exotune.sampled.loop) checked two independent ways:

* its pieces: the fractional-delay zero-order-hold discretization against a fine continuous
  simulation (scipy.signal.lsim with the delayed held input), and the assembled discrete controller
  against the continuous controller of docs/method.md#controller through the exact Tustin frequency identity
  H_d(e^{jωT_s}) = H(j (2/T_s) tan(ωT_s/2));
* its verdicts: at a high sample rate the sampled-data loop agrees with the continuous exact-delay
  analysis (exotune.analysis.counting.coupled_stable) on random designs, humans and environments, and the
  light-inertia boundary of the §9 design converges to the continuous one.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.analysis import analyze_design
from exotune.analysis.counting import coupled_stable
from exotune.config import load_design
from exotune.model.controller import build_controller
from exotune.sampled.loop import Measured, closed_loop_matrix, discretize, plant_ss, sampled_stable, zoh_fractional

ROOT = Path(__file__).resolve().parents[2]
BASE = load_design(ROOT / "examples" / "paper.yaml")


def _cfg(alpha=8.0, delay=0.001, zeta=None, zeta_hat=None, kc=None, dob=True, dob_hz=None):
    d = dataclasses.replace(BASE.design, amplification=alpha,
                            **({"zeta": zeta} if zeta is not None else {}),
                            **({"zeta_hat": zeta_hat} if zeta_hat is not None else {}))
    im = BASE.implementation
    q = im.dob if dob else None
    if q is not None and dob_hz is not None:
        q = dataclasses.replace(q, cutoff_hz=dob_hz)
    im = dataclasses.replace(im, delay_s=delay, dob=q)
    pl = BASE.plant if kc is None else dataclasses.replace(BASE.plant, cuff_stiffness=kc)
    cfg = dataclasses.replace(BASE, design=d, implementation=im, plant=pl)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    return cfg, cs


@pytest.mark.parametrize("f", [0.0, 0.3, 0.75])
@pytest.mark.parametrize("d", [0, 2])
def test_fractional_delay_zoh_matches_fine_simulation(d, f):
    """x[k] from (Φ, Γ0, Γ1) with T = (d + f)T_s equals lsim (zero-order hold between grid
    points) of the continuous plant driven by the held, delayed command."""
    A, B, C = plant_ss(BASE.plant, {"inertia": 0.1, "damping": 1.0, "stiffness": 40.0}, "free")
    Ts = 1e-3
    K = 40
    rng = np.random.default_rng(d * 10 + int(10 * f))
    u = rng.normal(size=K)
    Phi, G0, G1 = zoh_fractional(A, B, Ts, f)
    x = np.zeros((K + 1, A.shape[0]))
    x[0] = rng.normal(size=A.shape[0]) * 1e-3
    ud = lambda j: u[j] if j >= 0 else 0.0  # noqa: E731
    for k in range(K):
        x[k + 1] = Phi @ x[k] + G0[:, 0] * ud(k - d) + G1[:, 0] * ud(k - d - 1)
    # continuous: τ_m(t) = u[j] on [j T_s + T, (j+1) T_s + T)
    T = (d + f) * Ts
    # uniform grid of T_s/20: every switching instant (f is a multiple of 0.05) is a grid point
    t = np.arange(20 * K + 1) * (Ts / 20)
    j = np.floor((t - T) / Ts + 1e-9).astype(int)
    tau = np.where(j >= 0, u[np.clip(j, 0, K - 1)], 0.0)
    sysc = scipy.signal.StateSpace(A, B, np.eye(A.shape[0]), np.zeros((A.shape[0], 1)))
    _, _, xs = scipy.signal.lsim(sysc, tau, t, X0=x[0], interp=False)
    at = np.arange(K + 1) * 20
    scale = np.max(np.abs(xs))
    np.testing.assert_allclose(x, xs[at], rtol=0, atol=1e-6 * scale)


def _ct(q, s):
    return np.polyval(np.ravel(q.num)[::-1], s) / np.polyval(np.ravel(q.den)[::-1], s)


@pytest.mark.parametrize("dob", [True, False])
def test_discrete_controller_is_the_tustin_image_of_spec_controller(dob):
    """Channel by channel, the assembled discrete controller (DOB algebraic loop solved) equals the
    continuous docs/method.md#controller controller at the Tustin-warped frequency, exactly:
    τ_cmd = [(G_θ − Q J_m s² − Q B_m s) θ_m + (G_s + Q) τ_s + G_c τ_c] / (1 − Q), the K + B s parts
    of G_θ and G_s on sampled positions and ideal sampled velocities."""
    cfg, cs = _cfg(dob=dob, delay=0.0)
    fs = 2000.0
    Ts = 1 / fs
    ctrl = discretize(cs, cfg.plant, fs)
    w = 2 * np.pi * np.array([0.3, 3.0, 30.0, 150.0, 600.0])
    z = np.exp(1j * w * Ts)
    nu = (2 / Ts) * np.tan(w * Ts / 2)  # warped frequency
    Jm, Bm = float(cfg.plant.J_m), float(cfg.plant.B_m)
    Q = _ct(cs.dob_q, 1j * nu) if dob else 0.0 * nu
    K1, B1 = -np.ravel(cs.motor_position.num)[:2]
    K2, B2 = np.ravel(cs.spring_torque.num)[:2]

    def dtf(i):  # discrete transfer function from input channel i at z
        out = []
        for zz in z:
            r = ctrl.Cc @ np.linalg.solve(zz * np.eye(ctrl.Ac.shape[0]) - ctrl.Ac, ctrl.Bc[:, i]) + ctrl.Dc[0, i]
            out.append(complex(np.ravel(r)[0]))
        return np.array(out)

    s = 1j * nu
    den = 1 - Q
    Q2 = Q * (Jm * s**2 + Bm * s)
    np.testing.assert_allclose(dtf(Measured.index("theta_m")), (-K1 - Q2) / den, rtol=1e-8)
    np.testing.assert_allclose(dtf(Measured.index("omega_m")), (-B1 + 0 * s) / den, rtol=1e-8)
    np.testing.assert_allclose(dtf(Measured.index("tau_s")), (K2 + Q) / den, rtol=1e-8)
    np.testing.assert_allclose(dtf(Measured.index("dtau_s")), (B2 + 0 * s) / den, rtol=1e-8)
    np.testing.assert_allclose(dtf(Measured.index("tau_c")), _ct(cs.cuff_torque, s) / den, rtol=1e-8)


def test_prewarped_tustin_is_exact_at_the_prewarp_frequency():
    """With prewarping at f_p, the discrete G_c equals the continuous one at f_p exactly."""
    cfg, cs = _cfg(dob=False, delay=0.0)
    fs, fp = 1000.0, 120.0
    ctrl = discretize(cs, cfg.plant, fs, prewarp={"tau_c": fp})
    zz = np.exp(2j * np.pi * fp / fs)
    i = Measured.index("tau_c")
    hd = ctrl.Cc @ np.linalg.solve(zz * np.eye(ctrl.Ac.shape[0]) - ctrl.Ac, ctrl.Bc[:, i]) + ctrl.Dc[0, i]
    np.testing.assert_allclose(complex(np.ravel(hd)[0]), _ct(cs.cuff_torque, 2j * np.pi * fp), rtol=1e-9)


def test_badly_scaled_block_prewarped_near_nyquist_is_accurate_and_quiet():
    """A 4th-order block prewarped at 499 Hz of a 1 kHz controller has a companion realization
    with ~1e10 coefficients (scipy warns of rcond ~1e-26 while discretizing it): its discrete
    response still equals H(K (z−1)/(z+1)) to ~1e-11, and no warning reaches the user."""
    import warnings

    from exotune.sampled.loop import tustin

    num = np.array([2.17411924e10, 1.02444596e10, 7.44571640e8, 8.40258869e6, 1.01233488e5])
    den = np.array([2.47059005e10, 6.22682763e9, 1.26081987e7, 5.02175179e3, 1.0])
    Ts, pw = 1e-3, 499.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Ad, Bd, Cd, Dd = tustin(num, den, Ts, pw)
    K = 2 * np.pi * pw / np.tan(np.pi * pw * Ts)
    for f in (1.0, 10.0, 100.0, 300.0, 450.0, 499.0):
        z = np.exp(2j * np.pi * f * Ts)
        s = K * (z - 1) / (z + 1)
        h = np.polyval(num[::-1], s) / np.polyval(den[::-1], s)
        hd = (Cd @ np.linalg.solve(z * np.eye(Ad.shape[0]) - Ad, Bd) + Dd)[0, 0]
        assert abs(hd - h) <= 1e-9 * abs(h)


def _cases(n, seed):
    rng = np.random.default_rng(seed)
    humans = [None, "spring", "mass", "msd", "massless_damped"]
    out = []
    for i in range(n):
        h = humans[i % len(humans)]
        hm = None
        if h == "spring":
            hm = {"stiffness": float(np.exp(rng.uniform(0, np.log(3e3))))}
        elif h == "mass":
            hm = {"inertia": float(np.exp(rng.uniform(np.log(1e-3), 0.0)))}
        elif h == "msd":
            hm = {"inertia": float(np.exp(rng.uniform(np.log(1e-3), 0.0))), "damping": float(rng.uniform(0, 3)),
                  "stiffness": float(rng.uniform(0, 300))}
        elif h == "massless_damped":
            hm = {"damping": float(rng.uniform(0.1, 5)), "stiffness": float(rng.uniform(0, 300))}
        env = ["free", "free", "locked", {"stiffness": float(rng.uniform(10, 3000))}][i % 4]
        out.append(dict(alpha=float(np.exp(rng.uniform(np.log(1.5), np.log(25)))), zeta=float(rng.uniform(0.4, 1.1)),
                        zeta_hat=float(rng.uniform(0.4, 1.1)), delay=float(rng.uniform(0, 0.004)),
                        kc=float(np.exp(rng.uniform(np.log(100), np.log(2000)))), dob=bool(rng.random() < 0.7),
                        dob_hz=float(np.exp(rng.uniform(np.log(20), np.log(120)))), human=hm, env=env))
    return out


def test_sampled_data_agrees_with_continuous_at_high_rate():
    """At 20 kHz (delays of non-integer samples) the sampled-data verdicts equal the continuous
    exact-delay verdicts wherever the continuous verdict is not at the edge of the sampling
    perturbation (unchanged between T and T + 1.5 T_s: the zero-order hold adds ≈ T_s/2)."""
    fs = 20000.0
    Ts = 1 / fs
    compared = agree = 0
    seen = set()
    for c in _cases(150, 11):
        cfg, cs = _cfg(c["alpha"], c["delay"], c["zeta"], c["zeta_hat"], c["kc"], c["dob"], c["dob_hz"])
        env = c["env"]
        v0 = coupled_stable(cfg.plant, cs, 1, human=c["human"], env=None if env == "free" else env)
        cfg2, cs2 = _cfg(c["alpha"], c["delay"] + 1.5 * Ts, c["zeta"], c["zeta_hat"], c["kc"], c["dob"], c["dob_hz"])
        v1 = coupled_stable(cfg2.plant, cs2, 1, human=c["human"], env=None if env == "free" else env)
        if not (v0["conclusive"][0] and v1["conclusive"][0]) or v0["stable"][0] != v1["stable"][0]:
            continue
        s, rho = sampled_stable(cfg.plant, cs, fs, human=c["human"], env=env)
        if abs(rho - 1.0) < 1e-9:
            continue  # marginal in floating point
        compared += 1
        seen.add(bool(v0["stable"][0]))
        assert s == bool(v0["stable"][0]), (c, rho)
        agree += 1
    assert compared >= 120 and seen == {True, False}, (compared, seen)


def test_light_inertia_boundary_converges_to_continuous():
    """§9 design: the lightest stable human inertia of the sampled-data loop at 20 kHz is within
    1 % of the exact continuous one (4.79e-3 kg·m²); at 1 kHz sampling moves it up."""
    r = analyze_design(BASE).to_dict()
    m_cont = r["humans"][0]["stable_intervals"][0][0]
    cfg, cs = _cfg()

    def boundary(fs):
        lo, hi = 1e-3, 1e-2
        assert not sampled_stable(cfg.plant, cs, fs, human={"inertia": lo})[0]
        assert sampled_stable(cfg.plant, cs, fs, human={"inertia": hi})[0]
        for _ in range(40):
            m = math.sqrt(lo * hi)
            if sampled_stable(cfg.plant, cs, fs, human={"inertia": m})[0]:
                hi = m
            else:
                lo = m
        return hi

    assert abs(boundary(20000.0) / m_cont - 1) < 0.01
    assert boundary(1000.0) > m_cont * 1.01


def test_closed_loop_matrix_shift_register_and_plant_shapes():
    """Plant state counts per human/environment model and the size of the loop with d whole
    delay samples (d + 1 shift states)."""
    assert plant_ss(BASE.plant, None, "free")[0].shape == (4, 4)
    assert plant_ss(BASE.plant, {"stiffness": 10.0}, "free")[0].shape == (4, 4)
    assert plant_ss(BASE.plant, {"damping": 1.0}, "free")[0].shape == (5, 5)
    assert plant_ss(BASE.plant, {"inertia": 0.1}, "locked")[0].shape == (4, 4)
    cfg, cs = _cfg(delay=0.0035)
    A, B, C = plant_ss(cfg.plant, {"inertia": 0.1}, "free")
    ctrl = discretize(cs, cfg.plant, 1000.0)
    M = closed_loop_matrix(A, B, C, ctrl)
    assert M.shape[0] == A.shape[0] + ctrl.Ac.shape[0] + 4  # d = 3, f = 0.5


def test_analyze_with_sample_rate_reports_the_sampled_data_check():
    """`analyze` with sample_rate_hz: the §9 design at 1 kHz keeps its free/locked/spring verdicts,
    but sampling raises the lightest stable inertia by > 5 % — reported as a boundary move and as
    a warning (the continuous analysis alone would call those inertias stable); at 20 kHz the
    move is < 1 %. Without a sample rate there is no sampled-data section."""
    assert analyze_design(BASE).to_dict()["sampled_data"] is None
    cfg = dataclasses.replace(BASE, implementation=dataclasses.replace(BASE.implementation, sample_rate_hz=1000.0))
    r = analyze_design(cfg).to_dict()
    sd = r["sampled_data"]
    assert sd["sample_rate_hz"] == 1000.0 and sd["free_stable"] and sd["locked_stable"]
    mass, spring, cplx = sd["humans"]
    assert spring["stable_points"] == spring["points"] and spring["disagreements"] == []
    assert "skipped" in cplx
    (b,) = mass["boundaries"]
    assert b["sampled"] > 1.05 * b["continuous"]
    lo, hi = b["sampled_unstable_where_continuous_stable"]
    assert lo == b["continuous"] and hi == b["sampled"]
    # the sampled boundary really separates sampled-data verdicts
    _, cs = _cfg()
    assert not sampled_stable(cfg.plant, cs, 1000.0, {"inertia": 0.99 * b["sampled"]}, prewarp={"tau_c": 80.0, "dob": 60.0})[0]
    assert sampled_stable(cfg.plant, cs, 1000.0, {"inertia": 1.01 * b["sampled"]}, prewarp={"tau_c": 80.0, "dob": 60.0})[0]
    assert any("UNSTABLE for human mass inertia" in w for w in r["warnings"])
    cfg20 = dataclasses.replace(BASE, implementation=dataclasses.replace(BASE.implementation, sample_rate_hz=20000.0))
    b20 = analyze_design(cfg20).to_dict()["sampled_data"]["humans"][0]["boundaries"][0]
    assert abs(b20["sampled"] / b20["continuous"] - 1) < 0.01


def test_zero_order_hold_acts_like_half_a_sample_of_extra_delay():
    """Classic sampled-data consistency: at 2 kHz the sampled light-inertia boundary (T = 1 ms)
    matches the exact continuous boundary with the delay T + T_s/2 within 2 %, while the
    continuous boundary at T itself is > 3 % lower (so the check can fail)."""
    fs = 2000.0
    cfg, cs = _cfg(delay=0.001)
    pw = {"tau_c": 80.0, "dob": 60.0}

    def bis(stable, lo=2e-3, hi=2e-2):
        assert not stable(lo) and stable(hi)
        for _ in range(40):
            m = math.sqrt(lo * hi)
            lo, hi = (lo, m) if stable(m) else (m, hi)
        return hi

    m_s = bis(lambda m: sampled_stable(cfg.plant, cs, fs, {"inertia": m}, prewarp=pw)[0])
    cfg_h, cs_h = _cfg(delay=0.001 + 0.5 / fs)
    m_c_half = bis(lambda m: bool(coupled_stable(cfg_h.plant, cs_h, 1, human={"inertia": m})["stable"][0]))
    m_c = bis(lambda m: bool(coupled_stable(cfg.plant, cs, 1, human={"inertia": m})["stable"][0]))
    assert abs(m_s / m_c_half - 1) < 0.02, (m_s, m_c_half)
    assert m_s / m_c > 1.03, (m_s, m_c)


def test_sampled_check_covers_environment_ranges():
    """Environment spring/mass ranges at the joint (cuff free) are checked like the human
    families: the §9 design with a joint spring range 10–10⁴ N·m/rad and a joint mass range
    0.01–10 kg·m² at 1 kHz, sampled verdicts against the continuous environment intervals."""
    from exotune.model.humans import EnvModel

    env = (EnvModel("locked"), EnvModel("spring", "stiffness", 10.0, 1e4), EnvModel("mass", "inertia", 0.01, 10.0))
    cfg = dataclasses.replace(BASE, environment=env,
                              implementation=dataclasses.replace(BASE.implementation, sample_rate_hz=1000.0))
    r = analyze_design(cfg).to_dict()
    sd = r["sampled_data"]["environment"]
    assert [e["kind"] for e in sd] == ["spring", "mass"]
    cont = {e["kind"]: e for e in r["environment"] if e["kind"] != "locked"}
    _, cs = _cfg()
    for e in sd:
        assert e["points"] == 24 and 0 <= e["stable_points"] <= 24
        # every reported disagreement is a real sampled-vs-continuous difference
        for d in e["disagreements"]:
            assert d["continuous_stable"] == any(a <= d["value"] <= b for a, b in cont[e["kind"]]["stable_intervals"])
            s, _ = sampled_stable(cfg.plant, cs, 1000.0, env={e["parameter"]: d["value"]},
                                  prewarp={"tau_c": 80.0, "dob": 60.0})
            assert s == d["sampled_stable"]
        for b in e["boundaries"]:
            assert b["sampled"] is None or 0.5 * b["continuous"] <= b["sampled"] <= 2 * b["continuous"]


def test_zoh_and_prewarped_tustin_match_python_control():
    """exotune's discretizations against python-control on small cases: the zero-order hold of the
    plant without fractional delay (``control.sample_system(..., 'zoh')``) and each prewarped
    Tustin controller block (``method='tustin', prewarp_frequency=ω``), compared as frequency
    responses on the unit circle."""
    import control

    from exotune.sampled.loop import tustin

    A, B, C = plant_ss(BASE.plant, {"inertia": 0.1, "damping": 2.0, "stiffness": 30.0}, "free")
    Ts = 1e-3
    Phi, G0, G1 = zoh_fractional(A, B, Ts, 0.0)
    ref = control.sample_system(control.ss(A, B, np.eye(A.shape[0]), 0), Ts, "zoh")
    np.testing.assert_allclose(Phi, ref.A, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(G0, ref.B, rtol=1e-9, atol=1e-12)
    assert np.all(G1 == 0)

    cfg, cs = _cfg()
    z = np.exp(1j * 2 * np.pi * np.array([1.0, 10.0, 60.0, 200.0]) * Ts)
    for blk, fp in ((cs.cuff_torque, 80.0), (cs.dob_q, 60.0)):
        Ad, Bd, Cd, Dd = tustin(blk.num, blk.den, Ts, fp)
        mine = np.array([(Cd @ np.linalg.solve(zz * np.eye(Ad.shape[0]) - Ad, Bd) + Dd).item() for zz in z])
        tf = control.tf(np.ravel(blk.num)[::-1], np.ravel(blk.den)[::-1])
        d = control.sample_system(tf, Ts, "tustin", prewarp_frequency=2 * np.pi * fp)
        theirs = np.array([complex(d(zz)) for zz in z])
        np.testing.assert_allclose(mine, theirs, rtol=1e-8)


# ---------------------------------------------------------------------------------------------
# spectral_verdict: stable / unstable / inconclusive near the limits of double precision
# ---------------------------------------------------------------------------------------------
def _similar(moduli, seed):
    """A real matrix Q diag(moduli) Qᵀ (Q orthogonal): eigenvalue moduli known exactly."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.normal(size=(len(moduli), len(moduli))))
    return q @ np.diag(moduli) @ q.T


@settings(max_examples=40)
@given(n=st.integers(2, 12), delta=st.floats(1e-9, 1e-3), sign=st.sampled_from([-1.0, 1.0]), seed=st.integers(0, 10_000))
def test_spectral_verdict_is_right_when_the_margin_exceeds_rounding(n, delta, sign, seed):
    from exotune.sampled.loop import spectral_verdict

    moduli = [0.3 + 0.6 * k / n for k in range(n - 1)] + [1.0 + sign * delta]
    stable, rho, err = spectral_verdict(_similar(moduli, seed))
    assert stable is (sign < 0)
    assert rho == pytest.approx(1.0 + sign * delta, abs=1e-12) and err < delta


@settings(max_examples=20)
@given(n=st.integers(2, 12), seed=st.integers(0, 10_000))
def test_spectral_verdict_on_the_unit_circle_is_inconclusive(n, seed):
    from exotune.sampled.loop import spectral_verdict

    moduli = [0.3 + 0.6 * k / n for k in range(n - 1)] + [1.0]
    stable, rho, err = spectral_verdict(_similar(moduli, seed))
    assert stable is None and abs(rho - 1.0) <= err


def test_spectral_verdict_drops_the_rigid_body_mode_only_when_asked():
    from exotune.sampled.loop import spectral_verdict

    M = np.diag([0.5, 1.0])
    assert spectral_verdict(M)[0] is None
    assert spectral_verdict(M, rigid_tol=1e-7) == (True, 0.5, pytest.approx(spectral_verdict(M, rigid_tol=1e-7)[2]))


def _physical_plant(p, hm, hb, hk):
    """The plant of docs/method.md#physical-model written out state by state (θ_m, θ̇_m, θ_j, θ̇_j,
    θ_h, θ̇_h), independently of plant_stack's linear forms."""
    Jm, Bm, Ks, Jj, Kc = (float(np.ravel(x)[0]) for x in (p.J_m, p.B_m, p.K_s, p.J_j, p.K_c))
    A = np.array([[0, 1, 0, 0, 0, 0],
                  [-Ks / Jm, -Bm / Jm, Ks / Jm, 0, 0, 0],
                  [0, 0, 0, 1, 0, 0],
                  [Ks / Jj, 0, -(Ks + Kc) / Jj, 0, Kc / Jj, 0],
                  [0, 0, 0, 0, 0, 1],
                  [0, 0, Kc / hm, 0, -(Kc + hk) / hm, -hb / hm]])
    B = np.array([[0.0], [1.0 / Jm], [0], [0], [0], [0]])
    C = np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [-Ks, 0, Ks, 0, 0, 0], [0, -Ks, 0, Ks, 0, 0],
                  [0, 0, -Kc, 0, Kc, 0]], dtype=float)
    return A, B, C


@settings(max_examples=25, deadline=None)
@given(members=st.lists(st.tuples(st.floats(1e-4, 10.0), st.floats(0.0, 20.0), st.floats(0.0, 500.0)),
                        min_size=1, max_size=5),
       delay_samples=st.sampled_from([0.0, 0.4, 1.0, 3.5]))
def test_stacked_plant_and_loop_matrices_match_the_equations(members, delay_samples):
    """plant_stack (the one plant construction: plant_ss, loop_spectra and the sweep's BatchLoops)
    against the equations written out by hand, and the stacked loop assembly against the layout
    [x; z; τ_cmd[k−1] … τ_cmd[k−d−1]] built entry by entry; stacks equal their members alone."""
    from exotune.sampled.loop import loop_matrices, plant_stack, plant_structure, split_delay

    cfg, cs = _cfg(delay=delay_samples / 1000.0)
    p = cfg.plant
    ctrl = discretize(cs, p, 1000.0)
    hm, hb, hk = (np.array(x) for x in zip(*members))
    k = hm.size
    joint = tuple(np.full(k, float(np.ravel(x)[0])) for x in (p.J_m, p.B_m, p.K_s, p.J_j, p.K_c))
    A, B, C = plant_stack(joint, (hm, hb, hk), (np.zeros(k),) * 3, plant_structure({"inertia": 1.0}))
    Ts = 1e-3
    d, f = split_delay(ctrl.delay_s, Ts)
    zoh = [zoh_fractional(A[i], B[i][:, None], Ts, f) for i in range(k)]
    M = loop_matrices(*(np.stack([z[j] for z in zoh]) for j in range(3)), C, ctrl)
    nz = ctrl.Ac.shape[0]
    for i in range(k):
        Ar, Br, Cr = _physical_plant(p, hm[i], hb[i], hk[i])
        np.testing.assert_allclose(A[i], Ar, rtol=1e-13, atol=0)
        np.testing.assert_array_equal(B[i][:, None], Br)
        np.testing.assert_allclose(C[i], Cr, rtol=1e-13, atol=0)
        single = plant_ss(p, {"inertia": hm[i], "damping": hb[i], "stiffness": hk[i]})
        assert all(np.array_equal(x, y) for x, y in zip(single, (A[i], B[i][:, None], C[i])))
        assert np.array_equal(M[i], closed_loop_matrix(*single, ctrl))
        Phi, G0, G1 = zoh[i]
        N = 6 + nz + d + 1
        u = np.concatenate([(ctrl.Dc @ Cr)[0], ctrl.Cc[0], np.zeros(d + 1)])
        ref = np.zeros((N, N))
        ref[:6, :6] = Phi
        if d == 0:
            ref[:6] += G0 @ u[None, :]
        else:
            ref[:6, 6 + nz + d - 1] += G0[:, 0]
        ref[:6, 6 + nz + d] += G1[:, 0]
        ref[6:6 + nz, :6] = ctrl.Bc @ Cr
        ref[6:6 + nz, 6:6 + nz] = ctrl.Ac
        ref[6 + nz] = u
        for j in range(1, d + 1):
            ref[6 + nz + j, 6 + nz + j - 1] = 1.0
        np.testing.assert_allclose(M[i], ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))


# --- the zero-order hold's rounding (expm_rounding): a light human mass on the cuff spring ------------

LIGHT = """\
plant: {motor_inertia: 0.44, motor_damping: 17.9, sea_stiffness: 1180.0, joint_inertia: 0.29, cuff_stiffness: 300.0}
design: {amplification: 8.0, felt_inertia: 0.25, felt_damping: 1.0, zeta: 0.7, zeta_hat: 0.7}
implementation:
  delay_s: 0.001
  sample_rate_hz: 1000.0
  gv_filter: {cutoff_hz: 80.0, damping: 0.7}
  derivative_filter: {cutoff_hz: 100.0}
  dob: {cutoff_hz: 60.0, damping: 0.7}
humans:
- {kind: mass, inertia: 3.0391953823131e-09}
environment:
- {kind: locked}
"""
LIGHT_MASS = 3.0391953823131e-09  # kg·m²: the cuff-spring resonance ω ≈ 3e5 rad/s is all but undamped


def _mp_expm(X: np.ndarray, digits: int = 40) -> np.ndarray:
    mp = pytest.importorskip("mpmath")
    with mp.workdps(digits):
        E = mp.expm(mp.matrix(X.tolist()))
        return np.array([[float(E[i, j]) for j in range(X.shape[1])] for i in range(X.shape[0])])


@pytest.mark.parametrize("inertia", [1e-9, LIGHT_MASS, 1e-7, 1e-5, 1e-3, 1.0])
@pytest.mark.parametrize("env", ["free", "locked"])
@pytest.mark.parametrize("frac", [1.0, 0.37])
def test_expm_rounding_covers_the_exponentials_error_against_40_digits(inertia, env, frac):
    """The estimate is at least the true error of scipy's exponential entry by entry (40-digit
    mpmath reference) on the augmented plant of a light to heavy human mass, where scaling and
    squaring of ‖A T_s‖ up to 1e8 leaves absolute errors of 1e-7 that a relative 8ε perturbation
    of the loop matrix does not represent."""
    import scipy.linalg

    from exotune.sampled.loop import expm_rounding

    A, B, _C = plant_ss(BASE.plant, {"inertia": inertia, "damping": 0.0, "stiffness": 0.0}, env)
    n = A.shape[0]
    X = np.zeros((n + 1, n + 1))
    X[:n, :n], X[:n, n:] = A * (1e-3 * frac), B * (1e-3 * frac)
    E = scipy.linalg.expm(X)
    err = np.abs(E - _mp_expm(X))
    est = expm_rounding(X, E)
    assert np.all(est >= 0.0)
    assert np.all(err <= est), np.max(err / np.maximum(est, 1e-300))


def test_a_near_undamped_light_mass_is_not_called_stable_by_certify_nor_the_batch(tmp_path):
    """A 3.04e-9 kg·m² mass on the cuff: in double precision the loop's radius is 1 − 2.9e-13 with a
    relative-8ε rounding estimate of 5.5e-14 ("stable", CERTIFIED before), while the loop built
    from a 50-digit zero-order hold has its mode on the unit circle to 1e-17. With the hold's
    rounding estimated (expm_rounding) the verdict is inconclusive in certify's loop_verdict,
    not stable in the sweep's batch, and export refuses the file."""
    mp = pytest.importorskip("mpmath")
    import exotune
    from exotune.controllerfile import load_controller_file
    from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
    from exotune.errors import RunFailed
    from exotune.sampled.batch import BatchLoops, Loop
    from exotune.sampled.loop import loop_matrices, loop_verdict, spectral_verdict, split_delay

    src = tmp_path / "light.yaml"
    src.write_text(LIGHT)
    with pytest.raises(RunFailed, match="inconclusive"):
        exotune.export(src, out=tmp_path / "refused.yaml")
    assert not (tmp_path / "refused.yaml").exists()
    out = tmp_path / "c.yaml"
    exotune.export(src, out=out, allow_uncertified=True)
    cf = load_controller_file(out)
    ctrl, plant = discrete_from_file(cf), plant_from_file(cf)
    human = {"inertia": LIGHT_MASS, "damping": 0.0, "stiffness": 0.0}
    A, B, C = plant_ss(plant, human, "free")
    M = closed_loop_matrix(A, B, C, ctrl)
    stable_bare, rho, _ = spectral_verdict(M, rigid_tol=1e-7)
    assert stable_bare is True and 1.0 - rho < 1e-11  # what the relative estimate alone says
    # the truth: the same loop with its hold from a 50-digit exponential
    Ts = 1.0 / cf.sample_rate_hz
    d, f = split_delay(cf.delay_s, Ts)
    assert f == 0.0
    n = A.shape[0]
    X = np.zeros((n + 1, n + 1))
    X[:n, :n], X[:n, n:] = A, B
    with mp.workdps(50):
        Ex = mp.expm(mp.matrix((X * Ts).tolist()))
        Phi = mp.matrix([[Ex[i, j] for j in range(n)] for i in range(n)])
        G0 = mp.matrix([[Ex[i, n]] for i in range(n)])
        Mhp = mp.matrix(loop_matrices(np.zeros((1, n, n)), np.zeros((1, n, 1)), np.zeros((1, n, 1)), C[None], ctrl)[0].tolist())
        ref = loop_matrices(np.zeros((1, n, n)), np.ones((1, n, 1)), np.zeros((1, n, 1)), C[None], ctrl)[0][:n]
        for i in range(n):
            for j in range(M.shape[1]):
                Mhp[i, j] = (Phi[i, j] if j < n else 0) + G0[i, 0] * mp.mpf(float(ref[i, j]))
        ev = sorted(mp.eig(Mhp, left=False, right=False), key=lambda e: abs(e - 1))
        true_margin = 1 - max(abs(e) for e in ev[1:])  # the rigid-body z = 1 set aside
    assert abs(true_margin) < (1.0 - rho) / 100  # float's margin is a rounding artefact
    assert loop_verdict(plant, ctrl, False, human)[0] is None
    bl = BatchLoops.of_controller(plant, ctrl, False)
    loop = Loop("h", human={"kind": "mass", "inertia": 1.0, "damping": 0.0, "stiffness": 0.0}, param="inertia")
    assert not bl.spectra(np.zeros(1, np.int64), loop, np.array([LIGHT_MASS]))[2][0]
