"""Compliance-pair algebra (paper Propositions 1-4, Table II) against python-control
interconnections and against the independent state-space reference (tests/reference_model.py).

Propositions, as interconnections of the 1×2 system θ = [C1 H1]·[τ_ext; τ_m]:
  1 Parallel(S1, C2):     a compliance C2 shares θ and takes part of τ_ext  -> feedback −C2⁻¹ into τ_ext
  2 Series(S1, C2):       θ = θ1 + C2 τ_ext                                -> parallel with [C2, 0]
  3 position controller:  τ_m = G θ + τ'                                  -> positive feedback G into τ_m
  4 force controller:     τ_m = G τ_ext + τ'                              -> pre-compensator [[1,0],[G,1]]
"""

from __future__ import annotations

import numpy as np
import control
import pytest

import reference_model as ref
from exotune.model.controller import FirstOrderFilter, Implementation, SecondOrderFilter, build_controller
from exotune.model.plant import CompliancePair, Plant, Tf, parallel, series, seven_systems, virtual_parallel, virtual_series
from exotune.model.shaping import DesignParams

PAPER_PLANT = dict(J_m=0.44, B_m=17.9, K_s=1180.0, J_j=0.29, K_c=300.0)
PAPER_DESIGN = dict(amplification=8.0, felt_inertia=0.25, felt_damping=1.0, zeta=0.7, zeta_hat=0.7)


# ----------------------------------------------------------------------------------------------
# random rational systems
# ----------------------------------------------------------------------------------------------
def rand_tf(rng, n_den, n_num=None):
    """Random proper SISO rational (ascending coefficients), roots spread over 2 decades."""
    n_num = n_den if n_num is None else n_num
    den = np.poly(-(10 ** rng.uniform(-1, 1, n_den)) * np.exp(1j * rng.uniform(-1.2, 1.2, n_den)))
    den = np.real_if_close(den).real
    num = rng.normal(size=n_num + 1) * 10 ** rng.uniform(-1, 1)
    # python-control wants descending; exotune Tf.rational wants ascending
    return num[::-1].copy(), den[::-1].copy()


def both(num_asc, den_asc):
    return Tf.rational(num_asc, den_asc), control.ss(control.tf(num_asc[::-1], den_asc[::-1]))


def static(D):
    D = np.atleast_2d(np.asarray(D, float))
    return control.ss(np.zeros((0, 0)), np.zeros((0, D.shape[1])), np.zeros((D.shape[0], 0)), D)


def row_sys(*sisos):
    """1×k system y = Σ_i sys_i u_i."""
    return control.series(control.append(*sisos), static(np.ones((1, len(sisos)))))


def s_points(rng, k=25):
    return 10 ** rng.uniform(-1.5, 1.5, k) * np.exp(1j * rng.uniform(-np.pi, np.pi, k))


def ctl_eval(sys, s):
    """python-control frequency response at complex points: (outputs, inputs, len(s))."""
    return np.asarray(sys(s, squeeze=False))


def assert_close(a, b, rtol=1e-9, what=""):
    a, b = np.asarray(a), np.asarray(b)
    err = np.abs(a - b) / (np.abs(a) + np.abs(b) + 1e-300)
    assert err.max() <= rtol, f"{what}: max relative error {err.max():.3g}"


SEEDS = list(range(12))


@pytest.mark.parametrize("seed", SEEDS)
def test_prop1_parallel_is_shared_position_feedback(seed):
    rng = np.random.default_rng(seed)
    (c1, C1s), (h1, H1s) = both(*rand_tf(rng, 2, 0)), both(*rand_tf(rng, 2, 1))
    n2, d2 = rand_tf(rng, 2, 2)  # biproper so that C2⁻¹ is proper
    c2, _ = both(n2, d2)
    C2inv = control.ss(control.tf(d2[::-1], n2[::-1]))
    P = row_sys(C1s, H1s)
    K = control.series(C2inv, static([[1.0], [0.0]]))  # θ -> [C2⁻¹ θ; 0]
    cl = control.feedback(P, K, sign=-1)
    S = parallel(CompliancePair(c1, h1), c2)
    s = s_points(rng)
    R = ctl_eval(cl, s)
    assert_close(S.C(s), R[0, 0], what="Parallel C")
    assert_close(S.H(s), R[0, 1], what="Parallel H")


@pytest.mark.parametrize("seed", SEEDS)
def test_prop2_series_adds_positions(seed):
    rng = np.random.default_rng(100 + seed)
    (c1, C1s), (h1, H1s), (c2, C2s) = both(*rand_tf(rng, 2, 1)), both(*rand_tf(rng, 3, 1)), both(*rand_tf(rng, 1, 1))
    cl = control.parallel(row_sys(C1s, H1s), row_sys(C2s, static([[0.0]])))
    S = series(CompliancePair(c1, h1), c2)
    s = s_points(rng)
    R = ctl_eval(cl, s)
    assert_close(S.C(s), R[0, 0], what="Series C")
    assert_close(S.H(s), R[0, 1], what="Series H")


@pytest.mark.parametrize("seed", SEEDS)
def test_prop3_position_controller_is_virtual_parallel(seed):
    rng = np.random.default_rng(200 + seed)
    (c1, C1s), (h1, H1s), (g, Gs) = both(*rand_tf(rng, 2, 0)), both(*rand_tf(rng, 2, 1)), both(*rand_tf(rng, 1, 1))
    P = row_sys(C1s, H1s)
    cl = control.feedback(P, control.series(Gs, static([[0.0], [1.0]])), sign=+1)  # τ_m = Gθ + τ'
    S1 = CompliancePair(c1, h1)
    S = parallel(S1, virtual_parallel(S1, g))
    s = s_points(rng)
    R = ctl_eval(cl, s)
    assert_close(S.C(s), R[0, 0], what="virtual parallel C")
    assert_close(S.H(s), R[0, 1], what="virtual parallel H")
    # with the sign of G flipped the result must differ (the test can fail)
    Sw = parallel(S1, virtual_parallel(S1, -g))
    assert np.max(np.abs(Sw.C(s) - R[0, 0]) / np.abs(R[0, 0])) > 1e-3


@pytest.mark.parametrize("seed", SEEDS)
def test_prop4_force_controller_is_virtual_series(seed):
    rng = np.random.default_rng(300 + seed)
    (c1, C1s), (h1, H1s), (g, Gs) = both(*rand_tf(rng, 2, 1)), both(*rand_tf(rng, 2, 0)), both(*rand_tf(rng, 2, 2))
    P = row_sys(C1s, H1s)
    # pre-compensator [τ; τ'] -> [τ; Gτ + τ']
    pre = control.parallel(static(np.eye(2)), control.series(static([[1.0, 0.0]]), Gs, static([[0.0], [1.0]])))
    cl = control.series(pre, P)
    S1 = CompliancePair(c1, h1)
    S = series(S1, virtual_series(S1, g))
    s = s_points(rng)
    R = ctl_eval(cl, s)
    assert_close(S.C(s), R[0, 0], what="virtual series C")
    assert_close(S.H(s), R[0, 1], what="virtual series H")


# ----------------------------------------------------------------------------------------------
# seven_systems vs python-control assembly of Table II and vs the physical reference
# ----------------------------------------------------------------------------------------------
def _paper_controller(plant_d, design_d, delay=0.0, dob=None, gv=(80.0, 0.7), fd=100.0):
    plant = Plant(*[np.array([plant_d[k]]) for k in ("J_m", "B_m", "K_s", "J_j", "K_c")])
    design = DesignParams(*[np.array([design_d[k]]) for k in ("amplification", "felt_inertia", "felt_damping", "zeta", "zeta_hat")])
    impl = Implementation(delay_s=delay, gv_filter=SecondOrderFilter(gv[0], gv[1]), derivative_filter=FirstOrderFilter(fd),
                          dob=None if dob is None else SecondOrderFilter(dob[0], dob[1]))
    cs, ds = build_controller(plant, design, impl)
    g = {k: float(np.ravel(getattr(ds.gains, k))[0]) for k in ("K1", "B1", "K2", "B2")}
    g["Gc"] = (np.atleast_2d(cs.cuff_torque.num)[0], np.atleast_2d(cs.cuff_torque.den)[0])
    scalar_plant = Plant(*[plant_d[k] for k in ("J_m", "B_m", "K_s", "J_j", "K_c")])
    return scalar_plant, cs, g


def _tf_of_rational(num_asc, den_asc):
    return Tf.rational(np.asarray(num_asc, float), np.asarray(den_asc, float))


def _exotune_S(plant, g, delay=0.0, dob=None):
    Gt = Tf(lambda s: -(g["K1"] + g["B1"] * s))
    Gs = Tf(lambda s: g["K2"] + g["B2"] * s)
    Gc = _tf_of_rational(*g["Gc"])
    act = None
    if dob is not None:
        wq, zq = 2 * np.pi * dob[0], dob[1]
        Q = Tf.rational([wq * wq], [wq * wq, 2 * zq * wq, 1.0])
        E = Tf.delay(delay)
        act = E / (1 - Q + Q * E)
    return seven_systems(plant, Gt, Gs, Gc, delay_s=delay, actuator=act)


def _ref_response(sys, s, out, inp):
    """Frequency response C (sI − A)⁻¹ B + D of the reference model at complex points."""
    i, o = ref.INPUTS.index(inp), ref.OUTPUTS.index(out)
    A, B, C, D = (np.asarray(m) for m in (sys.A, sys.B, sys.C, sys.D))
    n = A.shape[0]
    return np.array([C[o] @ np.linalg.solve(x * np.eye(n) - A, B[:, i]) + D[o, i] for x in np.atleast_1d(s)])


def _rand_variant(rng):
    p = {k: v * 10 ** rng.uniform(-0.7, 0.7) for k, v in PAPER_PLANT.items()}
    d = {k: v * 10 ** rng.uniform(-0.5, 0.5) for k, v in PAPER_DESIGN.items()}
    d["amplification"] = 1 + 15 * rng.uniform()
    return p, d


@pytest.mark.parametrize("seed", range(8))
def test_seven_systems_C7_C5_match_state_space_reference_zero_delay(seed):
    rng = np.random.default_rng(400 + seed)
    p, d = _rand_variant(rng)
    plant, cs, g = _paper_controller(p, d)
    S = _exotune_S(plant, g)
    sys = ref.closed_loop_system(p, g, {"T": 0.0}, None, "free")
    w = np.sqrt(p["K_s"] / p["J_m"])
    s = w * s_points(rng, 30)
    assert_close(S["S7"].C(s), _ref_response(sys, s, "theta_h", "tau_h"), 1e-7, "C7 = θ_h/τ_c")
    assert_close(S["S6"].C(s), _ref_response(sys, s, "theta_j", "tau_h"), 1e-7, "C6 = θ_j/τ_c")
    assert_close(S["S5"].C(s), _ref_response(sys, s, "theta_j", "tau_env"), 1e-7, "C5 = θ_j/τ_env")
    # with zero delay the DOB changes nothing
    sysq = ref.closed_loop_system(p, g, {"T": 0.0, "dob": {"cutoff_hz": 60.0, "damping": 0.7}}, None, "free")
    assert_close(S["S7"].C(s), _ref_response(sysq, s, "theta_h", "tau_h"), 1e-7, "C7 with DOB, T = 0")
    # python-control's own frequency response of the same model agrees (ss evaluation path)
    R = ctl_eval(sys, s[:5])
    assert_close(R[ref.OUTPUTS.index("theta_h"), ref.INPUTS.index("tau_h")], S["S7"].C(s[:5]), 1e-7, "control eval")


@pytest.mark.parametrize("seed", range(6))
def test_coupled_poles_are_roots_of_1_plus_Zh_C7(seed):
    """Each closed-loop eigenvalue λ of the reference with a human attached satisfies
    1 + Z_h(λ) C7(λ) = 0 with exotune's C7 (zero delay, no DOB)."""
    rng = np.random.default_rng(500 + seed)
    p, d = _rand_variant(rng)
    plant, cs, g = _paper_controller(p, d)
    C7 = _exotune_S(plant, g)["S7"].C
    for human in ({"kind": "spring", "stiffness": 10 ** rng.uniform(0, 4)}, {"kind": "mass", "inertia": 10 ** rng.uniform(-3, 0)}):
        lam = ref.closed_loop_poles(p, g, {"T": 0.0}, human, "free")
        if human["kind"] == "mass":  # rigid-body root at 0 is a pole of C7 too: drop it
            lam = np.delete(lam, np.argmin(np.abs(lam)))
        def f(x):
            return 1 + (human.get("stiffness", 0.0) + human.get("inertia", 0.0) * x**2) * C7(x)

        # Newton step to the nearest root of 1 + Z_h C7 must be tiny relative to |λ|
        h = 1e-6 * np.maximum(1.0, np.abs(lam))
        df = (f(lam + h) - f(lam - h)) / (2 * h)
        step = np.abs(f(lam) / df) / np.maximum(1.0, np.abs(lam))
        assert step.max() < 1e-6, (human, lam[np.argmax(step)], step.max())
        # and a point that is not an eigenvalue is not a root
        assert np.all(np.abs(f(lam * (1 + 1e-3)) / df) / np.maximum(1.0, np.abs(lam)) > 1e-6)


@pytest.mark.parametrize("seed", range(6))
def test_exact_delay_C7_matches_pade_reference_at_low_frequency(seed):
    rng = np.random.default_rng(600 + seed)
    p, d = _rand_variant(rng)
    T = 10 ** rng.uniform(-3.5, -2.5)
    dob = (10 ** rng.uniform(1.3, 2.0), 0.7)
    plant, cs, g = _paper_controller(p, d)
    S = _exotune_S(plant, g, delay=T, dob=dob)
    impl = {"T": T, "dob": {"cutoff_hz": dob[0], "damping": dob[1]}}
    sys = ref.closed_loop_system(p, g, impl, None, "free", pade_order=8)
    w = np.logspace(-1, np.log10(0.5 / T), 40)  # ω·T <= 0.5
    s = 1j * w
    exact = S["S7"].C(s)
    pade = _ref_response(sys, s, "theta_h", "tau_h")
    # Padé(8,8) phase error at ωT = 0.5 is ~1e-24; allow for the loop's amplification and rounding
    assert_close(exact, pade, 1e-7, "C7 exact delay vs Padé(8)")
    assert_close(S["S5"].C(s), _ref_response(sys, s, "theta_j", "tau_env"), 1e-7, "C5 exact delay vs Padé(8)")
    # sensitivity: a 20 % different delay is detected at these frequencies
    wrong = ref.closed_loop_system(p, g, dict(impl, T=1.2 * T), None, "free", pade_order=8)
    err = np.abs(exact - _ref_response(wrong, s, "theta_h", "tau_h")) / np.abs(exact)
    assert err.max() > 1e-5


def test_seven_systems_H1_uses_exact_delay():
    plant = Plant(**{"motor_inertia": 0.44, "motor_damping": 17.9, "sea_stiffness": 1180.0, "joint_inertia": 0.29})
    S = seven_systems(plant, Tf.const(0.0), Tf.const(0.0), Tf.const(0.0), delay_s=2e-3)
    s = 1j * np.logspace(0, 4, 7)
    np.testing.assert_allclose(S["S1"].H(s) / S["S1"].C(s), np.exp(-2e-3 * s), rtol=1e-13)


def test_seven_systems_accepts_batched_plant():
    """Regression (found while writing these tests): seven_systems failed for a batched Plant
    (array fields) because ``ndarray * Tf`` was dispatched to numpy, which built an object array of
    Tf's (``M.inv()`` -> AttributeError). Fixed by ``Tf.__array_ufunc__ = None``. The batched
    result must equal the per-plant scalar evaluation."""
    Jm = np.array([0.44, 0.5, 1.0])
    plant = Plant(Jm[:, None], np.array([[17.9], [10.0], [5.0]]), np.array([[1180.0], [900.0], [2000.0]]), np.array([[0.29], [0.2], [0.4]]), 300.0)
    s = 1j * np.array([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0]])
    S = seven_systems(plant, Tf(lambda x: -5.0 * x), Tf.const(0.1), Tf.const(2.0))
    got = S["S7"].C(s)
    for i in range(3):
        pi = Plant(float(Jm[i]), float(plant.B_m[i, 0]), float(plant.K_s[i, 0]), float(plant.J_j[i, 0]), 300.0)
        Si = seven_systems(pi, Tf(lambda x: -5.0 * x), Tf.const(0.1), Tf.const(2.0))
        np.testing.assert_allclose(got[i], Si["S7"].C(s[i]), rtol=1e-12)
