"""docs/method.md#analyses-and-metrics metrics of exotune.analysis against independent computations.

* docs/design-file.md reference values of examples/paper.yaml;
* DOB margins against the closed form of L_dob = ω_q² e^{−sT}/(s(s + 2ζω_q)) and python-control;
* C7 = Δ10/Δ00 and C6/C5 against the paper's Table II propositions (exotune.model.plant.seven_systems,
  exact delay, DOB as the modified actuator) and, at T = 0, against the state-space reference
  (tests/reference_model.py, gains and G_c rebuilt there from docs/method.md#controller, docs/method.md#double-compliance-shaping);
* every interior end point of a stable interval is a true stability boundary of the reference
  (eigenvalues, Padé delay), crossed at the reported frequency;
* the complex-stiffness (hysteretic) boundaries against the matched spring-damper at the
  crossing frequency, and their η → 0 limit;
* passivity (max phase excess, non-passive bands) against a dense grid of C7;
* amplification: DC = α, the −3 dB bandwidth, the minimum-phase flag against the roots of the
  (Padé-rationalized) numerator.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from pathlib import Path

import control
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from numpy.polynomial import polynomial as P
from scipy.optimize import brentq

from exotune.analysis import analyze_batch, analyze_design
from exotune.analysis.amplification_ratio import amplification
from exotune.analysis.charfun import amplification_qps, char_terms
from exotune.analysis.operator_passivity import c7_response
from exotune.analysis.dob import dob_margins
from exotune.config import batch_config, design_from_mapping, load_design, read_yaml
from exotune.model.controller import FirstOrderFilter, Implementation, SecondOrderFilter, build_controller
from exotune.model.plant import Plant, Tf, seven_systems
from exotune.model.shaping import DesignParams

from reference_model import pade_qp_roots, closed_loop_poles, closed_loop_system, coupled_verdict, has_rigid_body_mode, reference_gains, reference_gc

PAPER = Path(__file__).resolve().parents[2] / "examples" / "paper.yaml"
PAPER_MAP = read_yaml(PAPER)
SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------
def _mapping(design=None, implementation=None, plant=None, humans=None) -> dict:
    """examples/paper.yaml with some values replaced (sub-dicts are merged)."""
    m = copy.deepcopy(PAPER_MAP)
    for key, upd in (("design", design), ("implementation", implementation), ("plant", plant)):
        if upd:
            m[key].update(upd)
    if humans is not None:
        m["humans"] = humans
    return m


def _random_mapping(rng, humans, delays=(0.0, 0.0005, 0.001, 0.002), alpha=(2.0, 20.0)) -> dict:
    r = lambda x, n=4: float(np.round(x, n))
    return _mapping(
        design={
            "amplification": r(np.exp(rng.uniform(*np.log(alpha))), 3),
            "felt_inertia": r(np.exp(rng.uniform(np.log(0.05), np.log(0.5)))),
            "felt_damping": r(np.exp(rng.uniform(np.log(0.3), np.log(3.0)))),
            "zeta": r(rng.uniform(0.3, 1.2), 3),
            "zeta_hat": r(rng.uniform(0.3, 1.2), 3),
        },
        implementation={
            "delay_s": float(rng.choice(delays)),
            "gv_filter": {"cutoff_hz": r(np.exp(rng.uniform(np.log(40.0), np.log(200.0))), 1), "damping": 0.7},
            "derivative_filter": {"cutoff_hz": r(np.exp(rng.uniform(np.log(40.0), np.log(300.0))), 1)},
            "dob": None if rng.random() < 0.4 else {"cutoff_hz": r(rng.uniform(20.0, 100.0), 1), "damping": 0.7},
        },
        plant={"cuff_stiffness": r(np.exp(rng.uniform(np.log(100.0), np.log(2000.0))), 1)},
        humans=humans,
    )


def _reference_inputs(m: dict):
    """(plant, gains incl. G_c, impl) for tests/reference_model.py, rebuilt from the mapping with
    the reference's own docs/method.md#controller, docs/method.md#double-compliance-shaping formulas (no exotune code)."""
    p = m["plant"]
    plant = dict(J_m=p["motor_inertia"], B_m=p["motor_damping"], K_s=p["sea_stiffness"], J_j=p["joint_inertia"], K_c=p["cuff_stiffness"])
    im = m["implementation"]
    gains = reference_gains(plant, m["design"])
    gains["Gc"] = reference_gc(plant, m["design"], im["gv_filter"], im["derivative_filter"])
    return plant, gains, {"T": float(im["delay_s"]), "dob": im["dob"]}


def _controller(m: dict):
    cfg = design_from_mapping(m)
    cs, ds = build_controller(cfg.plant, cfg.design, cfg.implementation)
    return cfg, cs, ds


def _rational_tf(r) -> Tf:
    return Tf.rational(np.ravel(r.num), np.ravel(r.den))


def _actuator(cs, T) -> Tf | None:
    """E_eff = e^{−sT} d_q/(d_q − n_q + n_q e^{−sT}) (docs/method.md#controller DOB with a perfect model)."""
    if cs.dob_q is None:
        return None
    nq, dq = np.ravel(cs.dob_q.num), np.ravel(cs.dob_q.den)
    e = Tf.delay(T)
    N, D = Tf.rational(nq, [1.0]), Tf.rational(dq, [1.0])
    return e * D / (D - N + N * e)


def _rhp_radius(p0, p1) -> float:
    """Every RHP zero of P0 + P1 e^{−sT} (and of its Padé rational form) has |s| < R."""
    n = len(p0) - 1
    a = -np.abs(np.asarray(p0, float)).copy()
    a[n] = -a[n]
    a[: len(p1)] -= np.abs(np.asarray(p1, float))
    r = P.polyroots(a)
    r = r[(np.abs(r.imag) < 1e-9 * np.abs(r)) & (r.real > 0)].real
    return float(r.max())


def _ref_human(kind, fam, p):
    """Reference human dict for a family member with the ranged parameter = p."""
    h = {"kind": "msd" if kind == "msd" else kind, "inertia": fam.inertia, "damping": fam.damping, "stiffness": fam.stiffness}
    h[fam.param] = p
    return h


# ---------------------------------------------------------------------------------------------
# 2. docs/design-file.md reference values
# ---------------------------------------------------------------------------------------------
def test_paper_reference_values():
    r = analyze_design(load_design(PAPER)).to_dict()
    assert r["amplification"]["dc"] == pytest.approx(8.0, rel=1e-9)
    assert r["dob"]["phase_margin_deg"] == pytest.approx(51.2, abs=0.05)
    assert r["dob"]["gain_margin_db"] == pytest.approx(12.05, abs=0.01)
    assert r["dob"]["delay_margin_s"] == pytest.approx(3.65e-3, abs=0.01e-3)
    assert r["free_stable"] is True and r["free"]["rigid_body_roots"] == 1
    by_kind = {h["kind"]: h for h in r["humans"]}
    spring = by_kind["spring"]
    assert spring["robust"] is True and spring["conclusive"] is True
    assert spring["stable_intervals"] == [[1.0, 10000.0]]
    mass = by_kind["mass"]
    assert mass["robust"] is False and mass["conclusive"] is True
    assert len(mass["stable_intervals"]) == 1
    lo, hi = mass["stable_intervals"][0]
    assert hi == 1.0
    assert 1e-3 < lo < 1e-2
    assert mass["lowest_stable_value_below_range_top"] == lo
    assert any(c["value"] == lo for c in mass["critical"])


def test_paper_lightest_inertia_is_a_reference_boundary():
    """The lightest stable inertia of §9 against the reference eigenvalues (Padé 10 and 14)."""
    r = analyze_design(load_design(PAPER)).to_dict()
    lo = next(h for h in r["humans"] if h["kind"] == "mass")["stable_intervals"][0][0]
    plant, gains, impl = _reference_inputs(PAPER_MAP)
    for order in (10, 14):
        below, _ = coupled_verdict(plant, gains, impl, {"kind": "mass", "inertia": lo * 0.999}, pade_order=order)
        above, _ = coupled_verdict(plant, gains, impl, {"kind": "mass", "inertia": lo * 1.001}, pade_order=order)
        assert (below, above) == (False, True)
    # and the free exoskeleton / whole spring range are stable for the reference too
    assert coupled_verdict(plant, gains, impl, None, pade_order=12)[0]
    for k in np.geomspace(1.0, 1e4, 9):
        assert coupled_verdict(plant, gains, impl, {"kind": "spring", "stiffness": k}, pade_order=12)[0]


# ---------------------------------------------------------------------------------------------
# 3. DOB margins
# ---------------------------------------------------------------------------------------------
def _dob_cs(cutoff_hz, zeta, T):
    impl = Implementation(
        delay_s=T,
        gv_filter=SecondOrderFilter(80.0, 0.7),
        derivative_filter=FirstOrderFilter(100.0),
        dob=SecondOrderFilter(cutoff_hz, zeta),
    )
    plant = Plant(0.44, 17.9, 1180.0, 0.29, 300.0)
    cs, _ = build_controller(plant, DesignParams(8.0, 0.25, 1.0, 0.7, 0.7), impl)
    return cs


def _dob_closed_form(cutoff_hz, zeta, T):
    wq = 2 * math.pi * cutoff_hz
    wc = wq * math.sqrt(-2 * zeta**2 + math.sqrt(4 * zeta**4 + 1))
    pm = 90.0 - math.degrees(math.atan(wc / (2 * zeta * wq))) - math.degrees(wc * T)
    dm = (math.radians(pm) % (2 * math.pi)) / wc
    if T == 0:
        gm = math.inf
    else:
        f = lambda w: -90.0 - math.degrees(math.atan(w / (2 * zeta * wq))) - math.degrees(w * T) + 180.0
        # f decreases from +90 (ω → 0) and is ≤ 0 at ω = π/(2T), the −180° crossing is unique
        w180 = brentq(f, 1e-12, math.pi / (2 * T), xtol=1e-14, rtol=1e-15)
        gm = -20 * math.log10(wq * wq / (w180 * math.hypot(w180, 2 * zeta * wq)))
    return wc, pm, dm, gm


def _wrap180(x):
    return (x + 180.0) % 360.0 - 180.0


@SETTINGS
@given(
    cutoff=st.floats(5.0, 300.0),
    zeta=st.floats(0.3, 1.5),
    T=st.one_of(st.just(0.0), st.floats(1e-6, 0.01)),
)
def test_dob_margins_closed_form(cutoff, zeta, T):
    r = {k: float(v[0]) for k, v in dataclasses.asdict(dob_margins(_dob_cs(cutoff, zeta, T), 1)).items()}
    wc, pm, dm, gm = _dob_closed_form(cutoff, zeta, T)
    assert r["crossover_hz"] == pytest.approx(wc / (2 * math.pi), rel=1e-9)
    # exotune reports the continuous phase margin; an unstable loop's is ≤ 0, saturated at −180°
    assert r["phase_margin_deg"] == pytest.approx(max(pm, -180.0), abs=1e-7)
    # this L_dob (type 1, monotone gain and phase) closes stably iff its unwrapped PM > 0; an
    # unstable DOB loop tolerates no extra delay (0 s) instead of the wrapped PM/ω_c
    assert bool(r["stable"]) == (pm > 0)
    assert r["delay_margin_s"] == pytest.approx(dm if pm > 0 else 0.0, rel=1e-8, abs=1e-15)
    if T == 0:
        assert r["gain_margin_db"] == math.inf
    else:
        assert r["gain_margin_db"] == pytest.approx(gm, abs=1e-7)


@pytest.mark.parametrize("cutoff,zeta,T", [(60.0, 0.7, 1e-3), (25.0, 1.0, 4e-3)])
def test_dob_margins_python_control_pade(cutoff, zeta, T):
    """control.stability_margins on ω_q²/(s(s + 2ζω_q)) · Padé(T, 10)."""
    wq = 2 * math.pi * cutoff
    n, d = control.pade(T, 10)
    L = control.tf([wq * wq], [1.0, 2 * zeta * wq, 0.0]) * control.tf(n, d)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(L)
    r = {k: float(v[0]) for k, v in dataclasses.asdict(dob_margins(_dob_cs(cutoff, zeta, T), 1)).items()}
    assert r["gain_margin_db"] == pytest.approx(20 * math.log10(gm), abs=1e-6)
    assert r["phase_margin_deg"] == pytest.approx(pm, abs=1e-6)
    assert r["crossover_hz"] == pytest.approx(wgc / (2 * math.pi), rel=1e-8)
    assert r["delay_margin_s"] == pytest.approx(math.radians(pm) / wgc, rel=1e-8)


# ---------------------------------------------------------------------------------------------
# 4. frequency responses two independent ways
# ---------------------------------------------------------------------------------------------
W = np.geomspace(0.1, 1e4, 400)


def _fr_cases():
    rng = np.random.default_rng(404)
    cases = [("paper", PAPER_MAP)]
    cases.append(("paper_T0", _mapping(implementation={"delay_s": 0.0})))
    cases.append(("paper_T0_nodob", _mapping(implementation={"delay_s": 0.0, "dob": None})))
    cases.append(("paper_nodob", _mapping(implementation={"dob": None})))
    for i in range(6):
        cases.append((f"random{i}", _random_mapping(rng, PAPER_MAP["humans"])))
    return cases


@pytest.mark.parametrize("name,m", _fr_cases(), ids=[c[0] for c in _fr_cases()])
def test_c7_and_amplification_responses(name, m):
    cfg, cs, ds = _controller(m)
    T = float(m["implementation"]["delay_s"])
    ct = char_terms(cfg.plant, cs, 1)
    c7 = c7_response(ct, W[None, :])[0]
    S = seven_systems(cfg.plant, _rational_tf(cs.motor_position), _rational_tf(cs.spring_torque), _rational_tf(cs.cuff_torque),
                      delay_s=T, actuator=_actuator(cs, T))
    s = 1j * W
    np.testing.assert_allclose(c7, S["S7"].C(s), rtol=1e-9, atol=0)
    # C5 = Δ01/Δ00 and C6/C5 three ways
    idx = np.zeros(W.size, int)
    ev = lambda q: q.eval(idx, W, deriv=False)[0]
    c5 = ev(ct.qp("01")) / ev(ct.qp("00"))
    np.testing.assert_allclose(c5, S["S5"].C(s), rtol=1e-9, atol=0)
    num, den = amplification_qps(cfg.plant, cs, 1)
    r65 = ev(num) / ev(den)
    Kc = float(m["plant"]["cuff_stiffness"])
    np.testing.assert_allclose(r65, (c7 - 1.0 / Kc) / c5, rtol=1e-8, atol=0)  # C7 ≈ 1/K_c: cancellation
    np.testing.assert_allclose(r65, S["S6"].C(s) / S["S5"].C(s), rtol=1e-9, atol=0)
    if T == 0:
        plant, gains, impl = _reference_inputs(m)
        sys = closed_loop_system(plant, gains, impl, human=None, env="free")
        h = np.ravel(control.frequency_response(sys[sys.output_labels.index("theta_h"), sys.input_labels.index("tau_h")], W).complex)
        np.testing.assert_allclose(c7, h, rtol=1e-8, atol=0)
        # C5 = θ_j/τ_env of the reference (cuff free)
        h5 = np.ravel(control.frequency_response(sys[sys.output_labels.index("theta_j"), sys.input_labels.index("tau_env")], W).complex)
        np.testing.assert_allclose(c5, h5, rtol=1e-8, atol=0)


def test_c7_reference_with_pade_at_low_frequency():
    """With the delay (paper design, T = 1 ms, DOB) the Padé(14) reference agrees with the
    exact-delay C7 where Padé is accurate (ωT ≤ 2)."""
    cfg, cs, _ = _controller(PAPER_MAP)
    w = np.geomspace(0.1, 2000.0, 200)
    c7 = c7_response(char_terms(cfg.plant, cs, 1), w[None, :])[0]
    plant, gains, impl = _reference_inputs(PAPER_MAP)
    sys = closed_loop_system(plant, gains, impl, human=None, env="free", pade_order=14)
    h = np.ravel(control.frequency_response(sys[0, 0], w).complex)
    np.testing.assert_allclose(c7, h, rtol=1e-7, atol=0)


# ---------------------------------------------------------------------------------------------
# 5. stable-interval end points are true boundaries
# ---------------------------------------------------------------------------------------------
HUMANS5 = [
    {"kind": "mass", "inertia": [1e-4, 1.0], "damping": 0.0},
    {"kind": "mass", "inertia": [1e-4, 1.0], "damping": 0.5},
    {"kind": "spring", "stiffness": [1.0, 1e5], "damping": 0.0},
    {"kind": "spring", "stiffness": [1.0, 1e5], "damping": 1.0},
    {"kind": "msd", "inertia": [1e-4, 1.0], "stiffness": 50.0, "damping": 0.2},
    {"kind": "msd", "inertia": 0.05, "stiffness": [1.0, 1e5], "damping": 0.0},
]


def _interval_cases():
    rng = np.random.default_rng(55)
    cases = [("paper", _mapping(humans=HUMANS5))]
    for i in range(6):
        cases.append((f"random{i}", _random_mapping(rng, HUMANS5)))
    # two designs with pure-spring boundaries (see CS_DESIGNS below)
    cases += [(f"cs{i}", _mapping(humans=HUMANS5, **CS_DESIGNS[i])) for i in (0, 3)]
    return cases


def _near_axis_pole(poles, rigid):
    p = np.asarray(poles)
    if rigid:
        p = np.delete(p, int(np.argmin(np.abs(p))))
    p = p[p.imag > 0]
    return p[int(np.argmin(np.abs(p.real) / np.abs(p)))]


def test_interval_end_points_are_reference_boundaries(capsys):
    checked = skipped = 0
    for name, m in _interval_cases():
        cfg = design_from_mapping(m)
        out = analyze_batch(cfg).to_columns()
        plant, gains, impl = _reference_inputs(m)
        for i, fam in enumerate(cfg.humans):
            key = f"human{i}_{fam.kind}"
            assert out[f"{key}_conclusive"][0]
            crit = dict(out[f"{key}_critical"][0])
            ends = sorted({x for iv in out[f"{key}_stable_intervals"][0] for x in iv} - {fam.lo, fam.hi})
            for p in ends:
                v = []
                for order in (10, 14):
                    v.append(tuple(coupled_verdict(plant, gains, impl, _ref_human(fam.kind, fam, p * f), pade_order=order)[0] for f in (1 - 1e-4, 1 + 1e-4)))
                if v[0] != v[1]:
                    skipped += 1
                    continue
                below, above = v[0]
                assert below != above, (name, key, p)
                # the stable side agrees with the reported intervals
                inside = any(a <= p * (1 + 1e-4) <= b for a, b in out[f"{key}_stable_intervals"][0])
                assert above == inside, (name, key, p)
                # crossing frequency = the near-axis pole of the reference at p*
                h = _ref_human(fam.kind, fam, p)
                lam = _near_axis_pole(closed_loop_poles(plant, gains, impl, h, pade_order=14), has_rigid_body_mode(gains, h))
                assert abs(lam.real) <= 1e-5 * abs(lam), (name, key, p, lam)
                assert lam.imag / (2 * math.pi) == pytest.approx(crit[p], rel=1e-3), (name, key, p)
                checked += 1
    with capsys.disabled():
        print(f"\n[stable-interval end points] checked {checked}, skipped {skipped} (Padé orders disagree)")
    assert checked >= 25


# ---------------------------------------------------------------------------------------------
# 6. complex stiffness vs the matched spring-damper
# ---------------------------------------------------------------------------------------------
# designs found (by a search of random designs) to have complex-stiffness boundaries in [1, 1e5]
CS_DESIGNS = [
    dict(design={"amplification": 6.295, "felt_inertia": 0.1579, "zeta_hat": 0.841}, implementation={"delay_s": 0.003, "dob": None}, plant={"cuff_stiffness": 1613.0}),
    dict(design={"amplification": 8.215, "felt_inertia": 0.0605, "zeta_hat": 1.106}, implementation={"delay_s": 0.003, "dob": {"cutoff_hz": 31.8, "damping": 0.7}}, plant={"cuff_stiffness": 751.7}),
    dict(design={"amplification": 7.572, "felt_inertia": 0.0547, "zeta_hat": 0.404}, implementation={"delay_s": 0.003, "dob": {"cutoff_hz": 46.0, "damping": 0.7}}, plant={"cuff_stiffness": 687.3}),
    dict(design={"amplification": 6.151, "felt_inertia": 0.061, "zeta_hat": 0.805}, implementation={"delay_s": 0.003, "dob": {"cutoff_hz": 76.0, "damping": 0.7}}, plant={"cuff_stiffness": 122.1}),
    dict(design={"amplification": 13.374, "felt_inertia": 0.0534, "zeta_hat": 0.439}, implementation={"delay_s": 0.002, "dob": {"cutoff_hz": 71.0, "damping": 0.7}}, plant={"cuff_stiffness": 1490.3}),
]
CS_HUMANS = [
    {"kind": "spring", "stiffness": [1.0, 1e5], "damping": 0.0},
    {"kind": "complex_stiffness", "stiffness": [1.0, 1e5], "eta": 0.2},
    {"kind": "complex_stiffness", "stiffness": [1.0, 1e5], "eta": 0.5},
    {"kind": "complex_stiffness", "stiffness": [1.0, 1e5], "eta": 1e-9},
]


@pytest.mark.parametrize("d", CS_DESIGNS, ids=[f"cs{i}" for i in range(len(CS_DESIGNS))])
def test_complex_stiffness_matches_spring_damper(d):
    m = _mapping(humans=CS_HUMANS, **d)
    out = analyze_batch(design_from_mapping(m)).to_columns()
    plant, gains, impl = _reference_inputs(m)
    n_checked = 0
    for i, eta in ((1, 0.2), (2, 0.5)):
        key = f"human{i}_complex_stiffness"
        assert out[f"{key}_conclusive"][0]
        crit = dict(out[f"{key}_critical"][0])
        ends = sorted({x for iv in out[f"{key}_stable_intervals"][0] for x in iv} - {1.0, 1e5})
        for k in ends:
            w = 2 * math.pi * crit[k]
            # z(jω*) = k + jbω* = k(1 + jη): the same impedance at ω*, hence a pole at ±jω*
            h = {"kind": "spring", "stiffness": k, "damping": k * eta / w}
            for order in (10, 14):
                poles = closed_loop_poles(plant, gains, impl, h, pade_order=order)
                lam = poles[int(np.argmin(np.abs(poles - 1j * w)))]
                assert abs(lam.real) <= 1e-4 * abs(lam), (k, eta, lam)
                assert lam.imag == pytest.approx(w, rel=1e-6)
            n_checked += 1
    assert n_checked >= 1
    # η → 0: the hysteretic family becomes the pure spring family
    a = out["human0_spring_stable_intervals"][0]
    b = out["human3_complex_stiffness_stable_intervals"][0]
    assert len(a) == len(b)
    np.testing.assert_allclose(np.asarray(b, float), np.asarray(a, float), rtol=1e-6)


# ---------------------------------------------------------------------------------------------
# 7. passivity
# ---------------------------------------------------------------------------------------------
def _excess_deg(c):
    ph = np.degrees(np.angle(c))  # (−180°, 180°]
    # distance of the phase from the passive band [−180°, 0°] on the circle
    return np.where(ph > 0, np.minimum(ph, 180.0 - ph), 0.0)


def _passivity_cases():
    rng = np.random.default_rng(77)
    cases = [("paper", PAPER_MAP), ("paper_T0", _mapping(implementation={"delay_s": 0.0}))]
    cases += [(f"random{i}", _random_mapping(rng, PAPER_MAP["humans"])) for i in range(6)]
    return cases


@pytest.mark.parametrize("name,m", _passivity_cases(), ids=[c[0] for c in _passivity_cases()])
def test_passivity_against_dense_grid(name, m):
    cfg, cs, _ = _controller(m)
    out = analyze_batch(cfg).passivity
    best = float(out.max_phase_excess_deg[0])
    bands = out.nonpassive_band_hz[0]
    ct = char_terms(cfg.plant, cs, 1)
    w = np.geomspace(1e-2, 1e6, 400_000)
    c7 = c7_response(ct, w[None, :])[0]
    ex = _excess_deg(c7)
    assert best >= ex.max() - 1e-6
    assert best <= ex.max() + 0.01
    if ex.max() > 1e-3:
        assert bands, "a non-passive excursion > 1e-3 deg exists but no band is reported"
    for f0, f1 in bands:
        assert f0 < f1
        mid = 0.5 * (f0 + f1) if math.isfinite(f1) else 2.0 * f0
        cm = c7_response(ct, np.array([[2 * math.pi * mid]]))[0, 0]
        assert cm.imag > 0
        for f in (f0, f1):
            if math.isfinite(f) and f > 0:
                ce = c7_response(ct, np.array([[2 * math.pi * f]]))[0, 0]
                assert abs(ce.imag) <= 1e-8 * abs(ce)
    # every grid point with a clearly non-passive phase (excess ≥ 0.2°) lies in a reported band
    hz = w / (2 * math.pi)
    sel = ex >= 0.2
    if sel.any():
        inb = np.zeros(w.size, bool)
        for f0, f1 in bands:
            inb |= (hz >= f0) & (hz <= f1)
        assert inb[sel].all()


def test_the_band_holding_the_maximum_excess_is_listed_from_0_1_deg():
    """max_phase_excess_deg ≥ 0.1° ⇔ at least one band is listed, and one band holds the maximum:
    the listing threshold applies to the refined peak of that band, not only to its samples
    (a 0.104° excess used to come with no band). Checked on a batch around a design found with a
    0.104° excess and a sampled peak below 0.1°."""
    m = _mapping(plant={"cuff_stiffness": 632.4555320336759},
                 design={"amplification": 21.976006437563104, "zeta_hat": 1.37},
                 implementation={"delay_s": 0.0031, "dob": {"cutoff_hz": 173.3, "damping": 0.7}})
    cfg, cs, _ = _controller(m)
    out = analyze_batch(cfg).passivity
    best = float(out.max_phase_excess_deg[0])
    bands = out.nonpassive_band_hz[0]
    assert 0.1 <= best < 0.11
    assert len(bands) == 1
    ct = char_terms(cfg.plant, cs, 1)
    f0, f1 = bands[0]
    w = 2 * math.pi * np.linspace(f0, f1, 20_001)[1:-1]
    ex = _excess_deg(c7_response(ct, w[None, :])[0])
    assert ex.max() == pytest.approx(best, abs=1e-4)  # the band holds the maximum
    # the invariant on a batch of neighbours (α and ζ̂ varied around the design)
    base = design_from_mapping(m)
    n = 120
    rng = np.random.default_rng(4)
    bcfg = batch_config(base, {"design.amplification": 21.976 * np.exp(rng.uniform(-0.3, 0.3, n)),
                               "design.zeta_hat": rng.uniform(1.0, 1.8, n)})
    o = analyze_batch(bcfg).passivity
    ex = np.asarray(o.max_phase_excess_deg)
    nb = np.array([len(b) for b in o.nonpassive_band_hz])
    assert ((ex >= 0.1) == (nb > 0)).all()
    assert (nb > 0).any() and (nb == 0).any()


# ---------------------------------------------------------------------------------------------
# 8. amplification
# ---------------------------------------------------------------------------------------------
def _design_cs(alpha, fi, fd, z, zh, T, dob, Kc):
    plant = Plant(0.44, 17.9, 1180.0, 0.29, Kc)
    impl = Implementation(delay_s=T, gv_filter=SecondOrderFilter(80.0, 0.7), derivative_filter=FirstOrderFilter(100.0),
                          dob=SecondOrderFilter(dob, 0.7) if dob else None)
    cs, _ = build_controller(plant, DesignParams(alpha, fi, fd, z, zh), impl)
    return plant, cs


DESIGNS = dict(
    alpha=st.floats(1.0, 30.0),
    fi=st.floats(0.03, 0.5),
    fd=st.floats(0.3, 3.0),
    z=st.floats(0.3, 1.2),
    zh=st.floats(0.3, 1.2),
    T=st.one_of(st.just(0.0), st.floats(1e-5, 2e-3)),
    dob=st.one_of(st.none(), st.floats(20.0, 100.0)),
    Kc=st.floats(100.0, 2000.0),
)


def _ratio(num, den, row, w):
    idx = np.full(w.size, row)
    return num.eval(idx, w, deriv=False)[0] / den.eval(idx, w, deriv=False)[0]


@settings(SETTINGS, max_examples=60)
@given(**DESIGNS)
def test_amplification_dc_bandwidth_value_minimum_phase(alpha, fi, fd, z, zh, T, dob, Kc):
    plant, cs = _design_cs(alpha, fi, fd, z, zh, T, dob, Kc)
    r = {k: v[0] for k, v in amplification(plant, cs, 1).items()}
    assert r["dc"] == pytest.approx(alpha, rel=1e-9)
    num, den = amplification_qps(plant, cs, 1)
    bw = float(r["bandwidth_hz"])
    if math.isfinite(bw):
        assert abs(_ratio(num, den, 0, np.array([2 * math.pi * bw]))[0]) == pytest.approx(r["dc"] / math.sqrt(2), rel=1e-8)
    # minimum phase ⇔ the numerator quasi-polynomial has no RHP zero
    p0, p1 = num.p0[0], num.p1[0]
    if T == 0:
        roots = P.polyroots(P.polyadd(p0, p1))
        assume(np.min(np.abs(roots.real) / np.abs(roots)) > 1e-6)
        assert bool(r["minimum_phase"]) == (not np.any(roots.real > 0))
    else:
        assume(_rhp_radius(p0, p1) * T <= 12.0)  # every RHP zero lies where Padé 12 is accurate
        ra, rb = pade_qp_roots(p0, p1, T, 12), pade_qp_roots(p0, p1, T, 16)
        assume(np.sum(ra.real > 0) == np.sum(rb.real > 0))
        assume(min(np.min(np.abs(ra.real) / np.abs(ra)), np.min(np.abs(rb.real) / np.abs(rb))) > 1e-6)
        assert bool(r["minimum_phase"]) == (not np.any(ra.real > 0))


def _first_crossing_violations(alpha, fi, fd, z, zh, T, Kc, dob=60.0):
    """Designs (vectorized) whose |C6/C5| reaches dc/√2 on a dense grid *below* the reported
    bandwidth (or anywhere up to 10⁶ rad/s when the reported bandwidth is inf)."""
    n = len(alpha)
    plant, cs = _design_cs(alpha, fi, fd, z, zh, T, dob, Kc)
    r = amplification(plant, cs, n)
    num, den = amplification_qps(plant, cs, n)
    bad = []
    for i in range(n):
        dc, bw = float(r["dc"][i]), float(r["bandwidth_hz"][i])
        top = 2 * math.pi * bw * (1 - 1e-7) if math.isfinite(bw) else 1e6
        w = np.geomspace(1e-3, top, 20_000)
        mag = np.abs(_ratio(num, den, i, w))
        if np.any(mag <= dc / math.sqrt(2)):
            bad.append((i, bw, float(w[np.argmax(mag <= dc / math.sqrt(2))] / (2 * math.pi))))
    return bad


def test_bandwidth_is_the_first_crossing():
    """300 random designs with α ∈ [1.5, 30]: |C6/C5| stays above dc/√2 below the reported
    bandwidth (the *first* −3 dB frequency), and above it everywhere when it is reported inf."""
    rng = np.random.default_rng(8)
    n = 300
    lu = lambda a, b: np.exp(rng.uniform(np.log(a), np.log(b), n))
    args = (rng.uniform(1.5, 30.0, n), lu(0.03, 0.5), lu(0.3, 3.0), rng.uniform(0.3, 1.2, n), rng.uniform(0.3, 1.2, n),
            rng.choice([0.0, 5e-4, 1e-3, 2e-3], n), lu(100.0, 2000.0))
    assert _first_crossing_violations(*args) == []


@pytest.mark.parametrize(
    "design",
    [
        # paper.yaml plant/implementation (T = 1 ms, DOB 60 Hz), α = 1, felt_inertia 0.05:
        # reported bandwidth inf, but |C6/C5| falls to 0.664·dc (−3.6 dB) near 945 Hz
        dict(alpha=1.0, fi=0.05, fd=1.0, z=0.7, zh=0.7, T=1e-3, Kc=300.0, dob=60.0),
        # T = 0, no DOB: reported 717 Hz, but |C6/C5| dips to 0.7024·dc between 1.17 and 1.33 Hz
        dict(alpha=1.0, fi=0.048828125, fd=1.0, z=1.0, zh=1.0, T=0.0, Kc=100.0, dob=None),
    ],
    ids=["alpha1_paper_inf", "alpha1_T0_717Hz"],
)
def test_bandwidth_finds_shallow_dip(design):
    """Regression: shallow −3 dB dips inside one phase-refined interval (α = 1 designs) are found."""
    d = {k: (np.array([v]) if k != "dob" else v) for k, v in design.items()}
    assert _first_crossing_violations(**d) == []


@pytest.mark.parametrize("T,expected", [(0.0, True), (0.001, False)])
def test_paper_minimum_phase(T, expected):
    """The example design: C6/C5 is minimum phase without delay (all numerator roots in the LHP),
    and the 1 ms delay of §9 puts a zero pair in the RHP (≈ 650 ± 1470j rad/s, Padé 12 and 16)."""
    m = _mapping(implementation={"delay_s": T})
    cfg, cs, _ = _controller(m)
    r = amplification(cfg.plant, cs, 1)
    assert bool(r["minimum_phase"][0]) is expected
    assert bool(r["conclusive"][0])
    num, _ = amplification_qps(cfg.plant, cs, 1)
    if T == 0:
        roots = P.polyroots(P.polyadd(num.p0[0], num.p1[0]))
        assert np.all(roots.real < -1.0)
    else:
        for order in (12, 16):
            rr = pade_qp_roots(num.p0[0], num.p1[0], T, order)
            rhp = np.sort_complex(rr[rr.real > 0])
            assert rhp.size == 2
            assert rhp[1].real == pytest.approx(650.0, rel=0.01) and abs(rhp[1].imag) == pytest.approx(1469.0, rel=0.01)
    if T == 0.001:  # the §9 file itself (same design) through the single-design report
        assert analyze_design(load_design(PAPER)).to_dict()["amplification"]["minimum_phase"] is False


def test_dob_unstable_loop_has_zero_delay_margin():
    """Past the DOB's delay limit the closed DOB loop is unstable: the wrapped PM_k/ω_k of docs/method.md#analyses-and-metrics
    would read as a positive margin, exotune reports dob.stable = False and a 0 s margin. The
    limit itself is T + DM at 1 ms (3.654 ms extra): stable just below, unstable just above."""
    cfg = load_design(PAPER)
    lim = 0.001 + analyze_design(cfg).to_dict()["dob"]["delay_margin_s"]
    for T, stable in ((lim * 0.999, True), (lim * 1.001, False), (0.006, False)):
        c = dataclasses.replace(cfg, implementation=dataclasses.replace(cfg.implementation, delay_s=T))
        d = analyze_design(c).to_dict()["dob"]
        assert d["stable"] is stable
        assert (d["delay_margin_s"] > 0) is stable
        assert (d["phase_margin_deg"] > 0) is stable


def test_dob_generic_path_equals_closed_form_path():
    """The general L_dob margin code (any rational Q; here the standard Q written with both
    polynomials scaled by 2, which disables the closed-form fast path) gives the same margins."""
    from exotune.analysis.dob import dob_margins_rows

    rng = np.random.default_rng(3)
    n = 40
    wq = 2 * np.pi * rng.uniform(10.0, 200.0, n)
    z = rng.uniform(0.4, 1.2, n)
    T = rng.uniform(0.0, 0.006, n)
    nq = (wq**2)[:, None]
    dq = np.stack([wq**2, 2 * z * wq, np.ones(n)], axis=1)
    fast = dob_margins_rows(nq, dq, T)
    slow = dob_margins_rows(2 * nq, 2 * dq, T)
    assert np.array_equal(fast.stable, slow.stable)
    for k in ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "crossover_hz"):
        assert np.allclose(getattr(fast, k), getattr(slow, k), rtol=1e-7, atol=1e-9), k


def test_passivity_does_not_depend_on_the_human_families():
    """C7 is a property of the exoskeleton alone: the same excess and bands whatever families the
    file lists (regression: with no family of zero fixed impedance the passivity frequency set was
    empty and the excess read 0)."""
    from exotune.model.humans import HumanFamily

    cfg = load_design(PAPER)
    ref = analyze_design(cfg).to_dict()["passivity"]
    assert ref["max_phase_excess_deg"] > 1.0
    for humans in ((), (HumanFamily("msd", "inertia", 0.06, 0.15, damping=1.0, stiffness=20.0),),
                   (HumanFamily("spring", "stiffness", 1.0, 100.0, damping=3.0),)):
        r = analyze_design(dataclasses.replace(cfg, humans=humans)).to_dict()["passivity"]
        assert r["max_phase_excess_deg"] == pytest.approx(ref["max_phase_excess_deg"], rel=1e-6)
        assert np.allclose(r["nonpassive_band_hz"], ref["nonpassive_band_hz"], rtol=1e-6)


def test_plant_margin_beside_the_rest_gives_the_serial_report(tmp_path):
    """``exotune analyze`` runs the plant-uncertainty margin in a forked child beside the rest of
    the analysis once the process is warm, or at once on the command line (exotune.numerics.beside):
    the report is the serial one, to the last digit. A fresh interpreter analyses the starter design
    twice (the first run is serial, the second forks when two CPUs are usable), once more with
    EXOTUNE_SERIAL set, and the command line analyses it once (forked)."""
    import json
    import os
    import subprocess
    import sys

    from exotune.starter import template_text

    design = tmp_path / "design.yaml"
    design.write_text(template_text("design.yaml"))
    script = ("import json, sys\nimport exotune.api as api\nimport exotune.numerics.beside as B\n"
              "seen = []\norig = B.Beside.result\n"
              "def result(self):\n    seen.append(self.forked)\n    return orig(self)\n"
              "B.Beside.result = result\n"
              "a = api.analyze(sys.argv[1]).to_json()\nb = api.analyze(sys.argv[1]).to_json()\n"
              "print(json.dumps({'forked': seen, 'can_fork': B.can_fork(), 'a': a, 'b': b}))\n")
    env = {k: v for k, v in os.environ.items() if k != "EXOTUNE_SERIAL"}
    out = []
    for extra in ({}, {"EXOTUNE_SERIAL": "1"}):
        p = subprocess.run([sys.executable, "-c", script, str(design)], capture_output=True, text=True,
                           env={**env, **extra}, timeout=600)
        assert p.returncode == 0, p.stderr
        out.append(json.loads(p.stdout.strip().splitlines()[-1]))
    forked, serial = out
    # per run: the margin, then its witnesses' confirmation (inside the margin's process)
    assert serial["forked"] == [False] * 4
    assert forked["forked"] == ([False, False, True] if forked["can_fork"] else [False] * 4)
    assert json.loads(forked["a"])["margins"]["plant_uncertainty"]["lower"] > 0  # robust: the margin is real work
    assert forked["a"] == forked["b"] == serial["a"] == serial["b"]
    # the command line declares its process one-shot: the first run already forks
    p = subprocess.run([sys.executable, "-m", "exotune", "analyze", str(design), "--json"], capture_output=True,
                       text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    assert p.stdout.rstrip("\n") == serial["a"]
