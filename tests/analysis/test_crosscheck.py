"""Coupled-stability verdicts of exotune (argument principle, exact delay) against closed-loop
eigenvalues of the independent state-space reference (tests/reference_model.py, Padé delay).

docs/method.md#analyses-and-metrics: "Stability with an exact delay ... cross-check with closed-loop eigenvalues of a rational
(Padé or sampled-data) model." Cases within 0.5 % of a stability boundary (the reference verdict
changes when the human parameter is scaled by 1.005 or 1/1.005), or where two Padé orders
disagree, are skipped and counted; the test prints the counts and requires ≥ 500 compared cases.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
import pytest

from exotune.analysis.charfun import char_terms
from exotune.analysis.counting import coupled_stable
from exotune.model.controller import FirstOrderFilter, Implementation, SecondOrderFilter, build_controller
from exotune.model.plant import Plant
from exotune.model.shaping import DesignParams

from reference_model import closed_loop_poles, has_rigid_body_mode

PLANT = dict(J_m=0.44, B_m=17.9, K_s=1180.0, J_j=0.29, K_c=300.0)


def _random_cases(n, seed):
    rng = np.random.default_rng(seed)
    lu = lambda a, b, size=n: np.exp(rng.uniform(np.log(a), np.log(b), size))
    cases = dict(
        alpha=lu(1.5, 20.0),
        felt_inertia=lu(0.05, 0.5),
        felt_damping=lu(0.3, 3.0),
        zeta=rng.uniform(0.3, 1.2, n),
        zeta_hat=rng.uniform(0.3, 1.2, n),
        delay=rng.choice([0.0, 0.0005, 0.001, 0.002, 0.003], n),
        fv=lu(40.0, 200.0),
        fd=lu(40.0, 300.0),
        Kc=lu(100.0, 2000.0),
    )
    return cases


def _exotune(cases, dob, human):
    n = len(cases["alpha"])
    plant = Plant(PLANT["J_m"], PLANT["B_m"], PLANT["K_s"], PLANT["J_j"], cases["Kc"])
    design = DesignParams(cases["alpha"], cases["felt_inertia"], cases["felt_damping"], cases["zeta"], cases["zeta_hat"])
    impl = Implementation(
        delay_s=cases["delay"],
        gv_filter=SecondOrderFilter(cases["fv"], 0.7),
        derivative_filter=FirstOrderFilter(cases["fd"]),
        dob=SecondOrderFilter(dob, 0.7) if dob else None,
    )
    cs, ds = build_controller(plant, design, impl)
    res = coupled_stable(plant, cs, n, human=human)
    return res, cs, ds


def _reference(cases, i, cs, ds, dob, human, scale=1.0, order=10):
    plant = dict(PLANT, K_c=float(cases["Kc"][i]))
    g = ds.gains
    gains = dict(K1=float(g.K1[i]), B1=float(g.B1[i]), K2=float(g.K2[i]), B2=float(g.B2[i]),
                 Gc=(cs.cuff_torque.num[i], cs.cuff_torque.den[i]))
    impl = dict(T=float(cases["delay"][i]), dob={"cutoff_hz": dob, "damping": 0.7} if dob else None)
    h = None
    if human is not None:
        h = {k: float(np.asarray(v)[i]) * (scale if k == _ranged(human) else 1.0) for k, v in human.items()}
        h["kind"] = "msd"
    poles = closed_loop_poles(plant, gains, impl, h, "free", pade_order=order)
    if has_rigid_body_mode(gains, h, "free"):
        poles = np.delete(poles, int(np.argmin(np.abs(poles))))
    return bool(np.max(poles.real) < 0)


def _ranged(human):
    return "inertia" if "inertia" in human else "stiffness"


@pytest.mark.parametrize(
    "kind,seed",
    [("free", 1), ("mass", 2), ("spring", 3), ("msd", 4)],
)
def test_verdicts_match_eigenvalues(kind, seed, capsys):
    n = 160
    cases = _random_cases(n, seed)
    rng = np.random.default_rng(seed + 100)
    if kind == "free":
        human = None
    elif kind == "mass":
        human = {"inertia": np.exp(rng.uniform(np.log(1e-3), np.log(1.0), n)), "damping": rng.choice([0.0, 0.5], n)}
    elif kind == "spring":
        human = {"stiffness": np.exp(rng.uniform(np.log(1.0), np.log(1e4), n)), "damping": rng.choice([0.0, 1.0], n)}
    else:
        human = {
            "inertia": np.exp(rng.uniform(np.log(1e-3), np.log(0.3), n)),
            "damping": rng.uniform(0.0, 2.0, n),
            "stiffness": np.exp(rng.uniform(np.log(1.0), np.log(500.0), n)),
        }
    compared = skipped = 0
    mismatches = []
    for dob in (None, 60.0):
        res, cs, ds = _exotune(cases, dob, human)
        assert res["conclusive"].mean() > 0.95
        for i in range(n):
            if not res["conclusive"][i]:
                skipped += 1
                continue
            ref = _reference(cases, i, cs, ds, dob, human)
            ref_hi_order = _reference(cases, i, cs, ds, dob, human, order=14)
            near = ref != ref_hi_order
            if human is not None and not near:
                near = (_reference(cases, i, cs, ds, dob, human, scale=1.005) != ref) or (
                    _reference(cases, i, cs, ds, dob, human, scale=1 / 1.005) != ref
                )
            if near:
                skipped += 1
                continue
            compared += 1
            if bool(res["stable"][i]) != ref:
                mismatches.append((i, dob, bool(res["stable"][i]), ref))
    with capsys.disabled():
        print(f"\n[{kind}] compared {compared} cases, skipped {skipped} (near a boundary / Padé-sensitive / inconclusive)")
    assert not mismatches, mismatches[:5]
    assert compared >= 125  # 4 kinds x >= 125 = >= 500 compared cases in total


def test_both_verdicts_occur():
    """The random cases above must contain stable and unstable designs, or the test proves little."""
    cases = _random_cases(160, 2)
    rng = np.random.default_rng(102)
    human = {"inertia": np.exp(rng.uniform(np.log(1e-3), np.log(1.0), 160)), "damping": np.zeros(160)}
    res, _, _ = _exotune(cases, 60.0, human)
    assert 0.1 < res["stable"].mean() < 0.95


def test_light_inertia_trap_matches_eigenvalues():
    """A 10⁻⁴…10⁻³ kg·m² mass on the cuff spring: a very lightly damped resonance (docs/method.md#analyses-and-metrics trap)."""
    cases = _random_cases(40, 7)
    human = {"inertia": np.geomspace(1e-4, 3e-3, 40), "damping": np.zeros(40)}
    res, cs, ds = _exotune(cases, 60.0, human)
    agree = 0
    for i in range(40):
        ref = _reference(cases, i, cs, ds, 60.0, human, order=12)
        if ref != _reference(cases, i, cs, ds, 60.0, human, order=16):
            continue
        assert bool(res["stable"][i]) == ref, i
        agree += 1
    assert agree >= 30


@pytest.mark.parametrize("env_kind", ["spring", "mass", "locked"])
def test_environment_verdicts_match_eigenvalues(env_kind):
    """Environment at the joint (cuff free): locked output, springs and masses (docs/method.md#analyses-and-metrics)."""
    n = 80
    cases = _random_cases(n, 11)
    rng = np.random.default_rng(12)
    plant = Plant(PLANT["J_m"], PLANT["B_m"], PLANT["K_s"], PLANT["J_j"], cases["Kc"])
    design = DesignParams(cases["alpha"], cases["felt_inertia"], cases["felt_damping"], cases["zeta"], cases["zeta_hat"])
    impl = Implementation(delay_s=cases["delay"], gv_filter=SecondOrderFilter(cases["fv"], 0.7),
                          derivative_filter=FirstOrderFilter(cases["fd"]), dob=SecondOrderFilter(60.0, 0.7))
    cs, ds = build_controller(plant, design, impl)
    if env_kind == "locked":
        env = "locked"
        values = np.zeros(n)
    elif env_kind == "spring":
        values = np.exp(rng.uniform(np.log(10.0), np.log(1e5), n))
        env = {"stiffness": values, "damping": np.full(n, 2.0)}
    else:
        values = np.exp(rng.uniform(np.log(1e-3), np.log(10.0), n))
        env = {"inertia": values, "damping": np.zeros(n)}
    res = coupled_stable(plant, cs, n, human=None, env=env)
    compared = 0
    for i in range(n):
        p = dict(PLANT, K_c=float(cases["Kc"][i]))
        g = ds.gains
        gains = dict(K1=float(g.K1[i]), B1=float(g.B1[i]), K2=float(g.K2[i]), B2=float(g.B2[i]),
                     Gc=(cs.cuff_torque.num[i], cs.cuff_torque.den[i]))
        im = dict(T=float(cases["delay"][i]), dob={"cutoff_hz": 60.0, "damping": 0.7})

        def verdict(scale=1.0, order=10):
            if env_kind == "locked":
                e = "locked"
            elif env_kind == "spring":
                e = {"kind": "spring", "stiffness": values[i] * scale, "damping": 2.0}
            else:
                e = {"kind": "mass", "inertia": values[i] * scale, "damping": 0.0}
            poles = closed_loop_poles(p, gains, im, None, e, pade_order=order)
            if has_rigid_body_mode(gains, None, e):
                poles = np.delete(poles, int(np.argmin(np.abs(poles))))
            return bool(np.max(poles.real) < 0)

        ref = verdict()
        if ref != verdict(order=14) or (env_kind != "locked" and (verdict(1.005) != ref or verdict(1 / 1.005) != ref)):
            continue
        assert res["conclusive"][i]
        assert bool(res["stable"][i]) == ref, (i, env_kind)
        compared += 1
    assert compared >= 70


def test_product_pade_crosscheck_agrees():
    """`exotune analyze --cross-check` (exotune.analysis.crosscheck): no disagreement on the §9 file, on the
    same file with masses down to 1e-6 kg·m², and on random designs; it reports its counts."""
    from pathlib import Path

    from exotune.config import load_design
    from exotune.analysis.crosscheck import pade_crosscheck
    from exotune.model.humans import HumanFamily

    root = Path(__file__).resolve().parents[2]
    base = load_design(root / "examples" / "paper.yaml")
    cfgs = [base, dataclasses.replace(base, humans=(HumanFamily("mass", "inertia", 1e-6, 1.0),))]
    rng = np.random.default_rng(21)
    for _ in range(4):
        d = dataclasses.replace(base.design, amplification=float(rng.uniform(2, 20)), zeta_hat=float(rng.uniform(0.4, 1.1)))
        im = dataclasses.replace(base.implementation, delay_s=float(rng.uniform(0, 0.003)))
        cfgs.append(dataclasses.replace(base, design=d, implementation=im))
    total = 0
    for cfg in cfgs:
        cc = pade_crosscheck(cfg)
        assert cc["disagreements"] == [], cc
        total += cc["checked"]
    assert total >= 40


def test_cli_cross_check_flag():
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-m", "exotune", "analyze", str(root / "examples" / "paper.yaml"), "--json",
                          "--cross-check"], capture_output=True, text=True, check=True)
    cc = json.loads(out.stdout)["cross_check"]
    assert cc["checked"] >= 5 and cc["agree"] == cc["checked"]


def _rhp_radius(ct_w, i, human):
    """Largest |s| with Σ|p1_k||s|^k + Σ_{k<n}|p0_k||s|^k ≥ |p0_n||s|^n (bisection in log |s|)."""
    ct, holder = ct_w
    t = ct.terms
    z = np.zeros(3) if human is None else np.array([holder["k"][i], 0.0, 0.0])
    from exotune.numerics.poly import padd, pmul

    p0 = padd(t["00"].p0[i], pmul(t["10"].p0[i], z))
    p1 = padd(t["00"].p1[i], pmul(t["10"].p1[i], z))
    p0 = np.trim_zeros(np.abs(p0), "b")
    a1 = np.abs(p1)
    n = len(p0) - 1
    f = lambda r: p0[n] * r**n - np.sum(p0[:n] * r ** np.arange(n)) - np.sum(a1 * r ** np.arange(len(a1)))
    lo, hi = 1e-6, 1e12
    for _ in range(200):
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if f(mid) <= 0 else (lo, mid)
    return hi


def test_wide_parameter_ranges_free_and_spring_verdicts():
    """Plants, designs and implementations spanning 3–5 decades each (inertias 1e-3…10 kg·m²,
    stiffnesses 10…1e5 N·m/rad, α 1…50, ζ 0.05…3, delays 0…20 ms, filters 5…1000 Hz, DOB 1…500 Hz):
    (compared only where the Padé model provably covers every RHP root: R·T ≤ 6)
    batch analysis runs without warnings, is conclusive, and agrees with closed-loop eigenvalues."""
    import warnings
    from pathlib import Path

    from exotune.analysis import analyze_batch
    from exotune.config import batch_config, load_design

    base = load_design(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml")
    rng = np.random.default_rng(11)
    n = 150
    lu = lambda a, b: np.exp(rng.uniform(np.log(a), np.log(b), n))
    ov = {"plant.motor_inertia": lu(1e-3, 10), "plant.motor_damping": lu(0.1, 100), "plant.sea_stiffness": lu(10, 1e5),
          "plant.joint_inertia": lu(1e-3, 10), "plant.cuff_stiffness": lu(10, 1e4),
          "design.amplification": lu(1, 50), "design.felt_inertia": lu(1e-3, 10), "design.felt_damping": lu(1e-2, 100),
          "design.zeta": lu(0.05, 3), "design.zeta_hat": lu(0.05, 3),
          "implementation.delay_s": rng.choice([0.0, 2e-4, 1e-3, 3e-3, 0.02], n), "implementation.gv_filter.cutoff_hz": lu(5, 1000),
          "implementation.derivative_filter.cutoff_hz": lu(5, 1000), "implementation.dob.cutoff_hz": lu(1, 500)}
    cfg = batch_config(base, ov)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cols = analyze_batch(cfg).to_columns()
    assert cols["free_conclusive"].all()
    cs, ds = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct_w = (char_terms(cfg.plant, cs, n), k_spring_holder := {})
    g = ds.gains
    k_spring = lu(1.0, 1e4)
    k_spring_holder["k"] = k_spring
    res_spring = coupled_stable(cfg.plant, cs, n, human={"stiffness": k_spring})
    compared = 0
    for i in range(n):
        P = cfg.plant
        plant = dict(J_m=P.J_m[i], B_m=P.B_m[i], K_s=P.K_s[i], J_j=P.J_j[i], K_c=P.K_c[i])
        gains = dict(K1=g.K1[i], B1=g.B1[i], K2=g.K2[i], B2=g.B2[i], Gc=(cs.cuff_torque.num[i], cs.cuff_torque.den[i]))
        im = cfg.implementation
        impl = dict(T=im.delay_s[i], dob={"cutoff_hz": im.dob.cutoff_hz[i], "damping": 0.7})
        for human, exo in ((None, cols["free_stable"][i]), ({"kind": "spring", "stiffness": k_spring[i]}, res_spring["stable"][i])):
            vs = []
            for order in (10, 16):
                p = closed_loop_poles(plant, gains, impl, human, "free", order)
                if has_rigid_body_mode(gains, human, "free"):
                    p = np.delete(p, np.argmin(np.abs(p)))
                lam = p[np.argmax(p.real)]
                vs.append((bool(lam.real < 0), lam))
            if vs[0][0] != vs[1][0] or abs(vs[1][1].real) < 1e-6 * abs(vs[1][1]):
                continue
            # the Padé model is trusted only where it can be: every RHP root of Δ (and of the Padé
            # model, |Padé| < 1 in the RHP) has |P0(s)| ≤ |P1(s)|, i.e. |s| ≤ R; require R·T ≤ 6
            if im.delay_s[i] * _rhp_radius(ct_w, i, human) > 6.0:
                continue
            assert vs[0][0] == bool(exo), (i, human, vs)
            compared += 1
    assert compared >= 60


def test_cross_check_catches_a_wrong_stable_interval(monkeypatch):
    """The second opinion is not a rubber stamp: if the intervals wrongly claimed the whole light-mass
    range stable, the Newton search on the exact Δ finds the RHP root and reports a disagreement."""
    from pathlib import Path

    import exotune.analysis.crosscheck as cc_mod
    from exotune.config import load_design
    from exotune.model.humans import HumanFamily

    base = load_design(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml")
    cfg = dataclasses.replace(base, humans=(HumanFamily("mass", "inertia", 1e-6, 1.0),))
    real = cc_mod.analyze_batch

    def lying(c):
        res = real(c)
        lie = dataclasses.replace(res.humans[0], stable_intervals=[[[1e-6, 1.0]]], critical=[[]])
        return dataclasses.replace(res, humans=(lie,))

    monkeypatch.setattr(cc_mod, "analyze_batch", lying)
    out = cc_mod.pade_crosscheck(cfg)
    assert out["disagreements"], out
    assert all(d["exotune_stable"] and d["rhp_root"]["re"] > 0 for d in out["disagreements"])


@settings(deadline=None, max_examples=40)
@given(T=st.floats(1e-5, 0.05), n=st.integers(1, 16))
def test_pade_coefficients_equal_python_control(T, n):
    """The closed-form Padé approximant of the cross-check is python-control's `control.pade`
    (the same rational function: compared on the imaginary axis and at a right-half-plane point)."""
    import control

    from exotune.analysis.crosscheck import pade_coefficients

    num, den = pade_coefficients(T, n)
    cn, cd = control.pade(T, n)
    s = np.array([1j * 0.3 / T, 1j * 3.0 / T, 0.5 / T + 1j / T])
    ours = np.polynomial.polynomial.polyval(s, num) / np.polynomial.polynomial.polyval(s, den)
    ref = np.polyval(cn, s) / np.polyval(cd, s)
    np.testing.assert_allclose(ours, ref, rtol=1e-9)


def _newton_reference(p0, p1, T, orders=(10, 16), n_seeds=600):
    """exact_rhp_roots as first written: numpy's polyval for each polynomial at every Newton step."""
    from exotune.analysis.crosscheck import pade_coefficients  # noqa: F401 (the module under test)
    from exotune.numerics.poly import padd, pmul
    from exotune.numerics.quasipoly import omega_max

    P = np.polynomial.polynomial
    R = float(omega_max(np.atleast_2d(p0), np.atleast_2d(p1))[0]) if T > 0 else 0.0
    seeds = []
    for n in orders:
        num, den = pade_coefficients(T, n)
        c = np.trim_zeros(np.asarray(padd(pmul(p0, den), pmul(p1, num)) if T > 0 else padd(p0, p1), complex), "b")
        k = np.nonzero(np.abs(c) > 0)[0]
        sig = (abs(c[k[0]]) / abs(c[-1])) ** (1.0 / max(len(c) - 1 - k[0], 1))
        sig = sig if np.isfinite(sig) and sig > 0 else 1.0
        seeds.append(np.roots((c * sig ** np.arange(len(c)))[::-1]) * sig)
    if T > 0 and np.isfinite(R):
        im = np.geomspace(1e-2, max(R, 1.0), n_seeds)
        seeds.append(0.05 * im + 1j * im)

    def newton_step(z):
        ez = np.exp(-z * T)
        value = P.polyval(z, p0) + P.polyval(z, p1) * ez
        slope = P.polyval(z, P.polyder(p0)) + (P.polyval(z, P.polyder(p1)) - T * P.polyval(z, p1)) * ez
        return z - value / slope

    z_all = np.concatenate(seeds)
    s = z_all[np.isfinite(z_all)]
    with np.errstate(all="ignore"):
        for _ in range(80):
            s = newton_step(s)
    found = []  # accepted one root at a time (scalar polyval), strongest real part first
    for z in s[np.isfinite(s)]:
        ez = np.exp(-z * T)
        residual = abs(P.polyval(z, p0) + P.polyval(z, p1) * ez)
        if residual <= 1e-9 * (P.polyval(abs(z), np.abs(p0)) + P.polyval(abs(z), np.abs(p1)) * abs(ez)) \
                and z.real > 1e-9 * abs(z):
            found.append(z)
    out = []
    for z in sorted(found, key=lambda x: -x.real):
        if all(abs(z - w) > 1e-6 * max(abs(z), 1.0) for w in out):
            out.append(z)
    return np.asarray(out, complex)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_exact_rhp_roots_one_pass_horner_is_polyvals(seed, hysteretic):
    """The Newton search evaluates its four polynomials in one stacked Horner pass (zero-padded
    rows): the roots are those of one ``polyval`` per polynomial (rounding-level tolerance)."""
    from exotune.analysis.crosscheck import exact_rhp_roots

    rng = np.random.default_rng(seed)
    n0 = int(rng.integers(3, 14))
    n1 = int(rng.integers(1, n0))
    p0 = rng.standard_normal(n0) * 10.0 ** rng.uniform(-4, 4, n0)
    p1 = rng.standard_normal(n1) * 10.0 ** rng.uniform(-4, 4, n1)
    if hysteretic:
        p0 = p0 + 1j * 0.2 * p0
    T = float(10 ** rng.uniform(-4, -2))
    got, ref = exact_rhp_roots(p0, p1, T), _newton_reference(p0, p1, T)
    assert got.shape == ref.shape
    order = lambda r: r[np.lexsort((r.imag, r.real))]  # noqa: E731 (conjugates tie on the real part)
    np.testing.assert_allclose(order(got), order(ref), rtol=1e-9, atol=0)


@pytest.mark.parametrize("T", [1e-300, 1e-100, 1e-20, 1e-13])
def test_a_vanishing_delay_gives_the_undelayed_pade_seeds(T):
    """``delay_s: 1e-300`` (any value from 1e-20 to 1e-100 too) made the Padé model's coefficients
    underflow: "Array must not contain infs or NaNs" (a bare LinAlgError through the API). Below
    PADE_MIN_DELAY_S the Padé seeds are the undelayed polynomial's roots."""
    from exotune.analysis.crosscheck import PADE_MIN_DELAY_S, exact_rhp_roots

    p0, p1 = np.array([2.0, 3.0, 1.0]), np.array([1.0, 0.5])
    r = exact_rhp_roots(p0, p1, T)
    assert T < PADE_MIN_DELAY_S and np.all(np.isfinite(r)) and r.size == 0  # 1.5 + 3.5 s + s² is stable
