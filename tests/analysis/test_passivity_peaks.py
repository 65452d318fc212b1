"""The maximum phase excess and the listed non-passive bands of C7 (exotune.analysis.operator_passivity,
paper §IV-A, docs/method.md#passivity-of-the-operator-compliance) against an independent dense reference.

The reference C7(jω) = θ_h/τ_h is solved here from the physical equations of tests/reference_model.py
(its gains and its G_c, the DOB written out, the exact delay e^{−jωT}); it shares no code with
exotune's characteristic function. It is sampled on a log grid plus 32 points per delay-ripple
period, refined until every step of arg C7 and log|C7| is below 0.01 and sin arg C7 changes by
less than a quarter of its size (so lobes and gaps near Im C7 = 0 are resolved); band edges are
brentq zeros of Im C7, and the peak of every band is the largest of its local maxima, each zoomed
in five times on 201 points.

Checked: the maximum to 1e-6 relative, and the listed bands: exactly the bands of the reference
whose peak reaches 0.1°, edges to 1e-7 relative. The regressions are designs of an independent
verification where the maximum was 0.28° low (a band whose sampled maximum was not the highest
held the peak) and where a band was merged over a passive gap with a sub-0.02° lobe beyond it, and
a design of a random campaign with a 0.32° band sampled once near its edge (0.023° reported).
"""

from __future__ import annotations

import copy
import functools
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize

from exotune.analysis import analyze_batch
from exotune.analysis.charfun import char_terms
from exotune.analysis.operator_passivity import c7_response
from exotune.config import batch_config, design_from_mapping
from exotune.config.yamlio import read_yaml
from exotune.model.controller import build_controller
from exotune.numerics.engine import numpy_engine

from reference_model import reference_gains, reference_gc

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "paper.yaml"
LISTED = 0.1  # [deg]
PAPER_PLANT = {"motor_inertia": 0.44, "motor_damping": 17.9, "sea_stiffness": 1180.0, "joint_inertia": 0.29,
               "cuff_stiffness": 300.0}


def _design(plant, design, delay, gv, deriv, dob):
    return {"plant": dict(plant), "design": dict(design),
            "implementation": {"delay_s": delay, "gv_filter": dict(gv), "derivative_filter": {"cutoff_hz": deriv},
                               "dob": dob}}


REGRESSIONS = {
    # the peak is in the second band (2.2863°); the first band's sampled maximum was higher (2.0077° reported)
    "second_band_peak": _design(PAPER_PLANT, {"amplification": 8.0, "felt_inertia": 0.25, "felt_damping": 0.02,
                                              "zeta": 0.7, "zeta_hat": 0.4}, 0.003,
                                {"cutoff_hz": 300.0, "damping": 0.05}, 100.0, {"cutoff_hz": 20.0, "damping": 0.7}),
    "ripple_lobes_peak": _design(PAPER_PLANT, {"amplification": 2.7831576837137404, "felt_inertia": 0.1,
                                               "felt_damping": 0.02, "zeta": 1.5, "zeta_hat": 0.2}, 0.005,
                                 {"cutoff_hz": 700.0, "damping": 0.1}, 300.0, {"cutoff_hz": 150.0, "damping": 0.2}),
    "ripple_lobes_peak_2": _design(PAPER_PLANT, {"amplification": 1.5, "felt_inertia": 0.1, "felt_damping": 0.02,
                                                 "zeta": 1.5, "zeta_hat": 0.4}, 0.004,
                                   {"cutoff_hz": 700.0, "damping": 0.1}, 300.0, {"cutoff_hz": 150.0, "damping": 0.2}),
    # a 0.00056° lobe beyond a 46 Hz passive gap had been merged with the band ending at 135.51 Hz
    "gap_before_tiny_lobe": _design(
        {"motor_inertia": 1.147716018567964, "motor_damping": 1.1916919816500808, "sea_stiffness": 1678.2678728242136,
         "joint_inertia": 0.8357020258352427, "cuff_stiffness": 334.7599611300002},
        {"amplification": 38.15585928210828, "felt_inertia": 0.3699706384279993, "felt_damping": 0.43610665291334005,
         "zeta": 0.12442521317034758, "zeta_hat": 0.025143723548401723}, 0.0009568333782899147,
        {"cutoff_hz": 365.60404274061887, "damping": 1.3537127494720989}, 58.44351069031175,
        {"cutoff_hz": 165.24699271034302, "damping": 0.01645134425396275}),
    # a 0.32° band (48.46–53.03 Hz, a lightly damped DOB) sampled once, at 0.0035° near its start:
    # its neighbours are passive, the clipped excess had no fall, and 0.023° (another band) was reported
    "band_sampled_once": _design(
        {"motor_inertia": 0.2488610596506417, "motor_damping": 20.111335578954165, "sea_stiffness": 1731.5236571664122,
         "joint_inertia": 0.1987162110710598, "cuff_stiffness": 153.70406421407446},
        {"amplification": 2.0398020760485234, "felt_inertia": 0.3548314629130087, "felt_damping": 0.2771381766021476,
         "zeta": 1.4911754203759815, "zeta_hat": 0.4938332252510107}, 0.003868131389489616,
        {"cutoff_hz": 52.4609754881145, "damping": 0.13643767213971944}, 67.3857531395623,
        {"cutoff_hz": 47.76063921275229, "damping": 0.011753980891691967}),
    # the same with a 0.0098° lobe (band 10.59–51.59 Hz had been listed as 10.59–79.74 Hz)
    "gap_before_small_lobe": _design(PAPER_PLANT, {"amplification": 15.326188647871062, "felt_inertia": 0.31622776601683794,
                                                   "felt_damping": 0.02, "zeta": 0.02, "zeta_hat": 0.2}, 0.0021,
                                     {"cutoff_hz": 80.0, "damping": 0.7}, 7.0, {"cutoff_hz": 60.0, "damping": 0.01}),
}


def _c7_exact(m):
    """C7(jω) of a design mapping [rad/(N·m)] as a function of ω [rad/s], and its delay [s]: the free
    joint without a human (τ_c = τ_h), solved from the motor and joint equations with the controller
    τ_cmd = −(K1 + B1 s)θ_m + (K2 + B2 s)τ_s + G_c τ_c − δ̂, the DOB δ̂ = Q[(J_m s² + B_m s)θ_m − τ_s − τ_cmd]
    and τ_m = e^{−sT} τ_cmd (tests/reference_model.py's equations)."""
    p = m["plant"]
    plant = {"J_m": p["motor_inertia"], "B_m": p["motor_damping"], "K_s": p["sea_stiffness"],
             "J_j": p["joint_inertia"], "K_c": p["cuff_stiffness"]}
    im = m["implementation"]
    g = reference_gains(plant, m["design"])
    gn, gd = reference_gc(plant, m["design"], im["gv_filter"], im["derivative_filter"])
    T = float(im.get("delay_s") or 0.0)
    dob = im.get("dob")
    Jm, Bm, Ks, Jj, Kc = (plant[k] for k in ("J_m", "B_m", "K_s", "J_j", "K_c"))
    pv = np.polynomial.polynomial.polyval

    def c7(w):
        s = 1j * np.asarray(w, dtype=float)
        E = np.exp(-s * T)
        M = Jm * s * s + Bm * s
        if dob:
            wq, zq = 2 * math.pi * float(dob["cutoff_hz"]), float(dob["damping"])
            dq = s * s + 2 * zq * wq * s + wq * wq
            Q, one_q = wq * wq / dq, s * (s + 2 * zq * wq) / dq
        else:
            Q, one_q = 0.0, 1.0
        kt = g["K2"] + g["B2"] * s
        # τ_cmd = a_m θ_m + a_j θ_j + a_0 (δ̂ solved out), τ_s = K_s (θ_j − θ_m), τ_c = 1
        a_m = (-(g["K1"] + g["B1"] * s) - kt * Ks - Q * M - Q * Ks) / one_q
        a_j = (kt * Ks + Q * Ks) / one_q
        a_0 = pv(s, gn) / pv(s, gd) / one_q
        # M θ_m = τ_s + e^{−sT} τ_cmd;  J_j s² θ_j = τ_c − τ_s
        a11, a12, b1 = M + Ks - E * a_m, -Ks - E * a_j, E * a_0
        a21, a22 = -Ks, Jj * s * s + Ks
        th_j = (a11 - a21 * b1) / (a11 * a22 - a12 * a21)
        return th_j + 1.0 / Kc

    return c7, T


def _excess(c):
    ph = np.degrees(np.angle(c))
    return np.where(np.imag(c) > 0, np.minimum(ph, 180.0 - ph), 0.0)


def _dense_reference(m):
    """The bands [Hz] with their peak excess [deg] (edges computed for the bands that may be
    listed), and the maximum excess [deg]."""
    c7, T = _c7_exact(m)
    Kc = float(m["plant"]["cuff_stiffness"])
    f_hi = 1e3  # beyond, |K_c C7 − 1| < 1e-5 over a decade: the excess is below 6e-4°
    while f_hi < 1e8 and np.max(np.abs(Kc * c7(2 * np.pi * np.geomspace(f_hi, 10 * f_hi, 4000)) - 1.0)) >= 1e-5:
        f_hi *= 10
    f = np.geomspace(1e-3, f_hi, int(np.log10(f_hi / 1e-3) * 400) + 1)
    if T > 0:
        f = np.union1d(f, np.arange(1.0 / (32 * T), f_hi, 1.0 / (32 * T)))
    for _ in range(40):
        c = c7(2 * np.pi * f)
        u = c.imag / np.abs(c)
        bad = (np.abs(np.angle(c[1:] / c[:-1])) > 0.01) | (np.abs(np.log(np.abs(c[1:] / c[:-1]))) > 0.01)
        bad |= np.abs(u[1:] - u[:-1]) > 0.25 * np.minimum(np.abs(u[1:]), np.abs(u[:-1])) + 1e-7
        bad &= (f[1:] - f[:-1]) > 1e-12 * f[1:]
        if not bad.any():
            break
        f = np.sort(np.r_[f, 0.5 * (f[:-1][bad] + f[1:][bad])])
    w = 2 * np.pi * f
    c = c7(w)
    ex = _excess(c)
    pos = c.imag > 0
    ch = np.flatnonzero(pos[1:] != pos[:-1])
    lo_i = ([0] if pos[0] else []) + [i + 1 for i in ch if not pos[i]]
    hi_i = [i for i in ch if pos[i]] + ([w.size - 1] if pos[-1] else [])
    floor = 0.5 * min(LISTED, float(ex.max()))  # lower lobes cannot matter (the grid resolves 25 %)

    def edge(i):
        return scipy.optimize.brentq(lambda x: float(c7(np.array([x]))[0].imag), w[i], w[i + 1],
                                     xtol=1e-15 * w[i], rtol=1e-15, maxiter=300)

    bands = []
    for i0, i1 in zip(lo_i, hi_i):
        sel = np.arange(i0, i1 + 1)
        pk = float(ex[sel].max())
        if pk < floor:
            bands.append((math.nan, math.nan, pk))
            continue
        if np.any(np.sign(c.real[sel][1:]) != np.sign(c.real[sel][:-1])):
            pk = 90.0  # the phase passes 90°
        else:
            e = ex[sel]
            loc = sel[(e >= np.r_[-1.0, e[:-1]]) & (e >= np.r_[e[1:], -1.0])]
            lo, hi = w[np.maximum(loc - 1, 0)], w[np.minimum(loc + 1, w.size - 1)]
            for _ in range(5):
                x = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, 201)[None, :]
                v = _excess(c7(x))
                k = np.argmax(v, axis=1)
                pk = max(pk, float(v.max()))
                xk, h = x[np.arange(k.size), k], (hi - lo) / 200
                lo, hi = np.maximum(xk - h, lo), np.minimum(xk + h, hi)
        a = w[0] if i0 == 0 and pos[0] else edge(i0 - 1)
        b = np.inf if i1 == w.size - 1 and pos[-1] else edge(i1)
        bands.append((a / (2 * np.pi), b / (2 * np.pi), pk))
    return bands, max([b[2] for b in bands], default=0.0)


@functools.lru_cache(maxsize=None)
def _reference_of(name):
    return _dense_reference(REGRESSIONS[name])


def _check(ref, top, bands):
    """exotune's maximum and bands of one design against the reference ``(bands, maximum)``."""
    rb, rtop = ref
    assert top == pytest.approx(rtop, rel=1e-6, abs=1e-9)
    listed = [(a, b) for a, b, pk in rb if pk >= LISTED * (1 + 1e-5)]
    # a band whose peak is the threshold itself may go either way
    either = [(a, b) for a, b, pk in rb if LISTED * (1 - 1e-5) <= pk < LISTED * (1 + 1e-5)]
    got = [tuple(x) for x in bands]

    def same(x, y, a, b):
        return abs(x - a) <= 1e-7 * a and (abs(y - b) <= 1e-7 * b or y == b == np.inf)

    for a, b in listed:
        assert any(same(x, y, a, b) for x, y in got), ((a, b), got)
    for x, y in got:
        assert any(same(x, y, a, b) for a, b in listed + either), ((x, y), listed)


def _passivity(mapping, engine="compiled"):
    cfg = batch_config(design_from_mapping(mapping), {})
    if engine == "numpy":
        with numpy_engine(), np.errstate(all="ignore"):
            return analyze_batch(cfg).passivity
    return analyze_batch(cfg).passivity


def test_the_reference_c7_is_the_analysed_c7():
    """The reference's C7 (physical equations, exact delay) equals exotune's Δ10/Δ00, with and
    without a DOB and a delay: the two describe the same loop."""
    w = np.geomspace(0.5, 5e4, 300)
    for m in (REGRESSIONS["second_band_peak"], REGRESSIONS["gap_before_tiny_lobe"],
              {**REGRESSIONS["second_band_peak"], "implementation": {**REGRESSIONS["second_band_peak"]["implementation"],
                                                                     "dob": None, "delay_s": 0.0}}):
        cfg = design_from_mapping(m)
        cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
        ours = c7_response(char_terms(cfg.plant, cs, 1), w[None, :])[0]
        np.testing.assert_allclose(_c7_exact(m)[0](w), ours, rtol=1e-9)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("name", sorted(REGRESSIONS))
def test_regressions_of_the_verification(name, engine):
    res = _passivity(REGRESSIONS[name], engine)
    _check(_reference_of(name), float(res.max_phase_excess_deg[0]), res.nonpassive_band_hz[0])


def test_the_peak_in_a_band_whose_samples_are_lower():
    """The verification's example: 2.2863° (second band), not the 2.0077° of the first band."""
    res = _passivity(REGRESSIONS["second_band_peak"])
    assert float(res.max_phase_excess_deg[0]) == pytest.approx(2.2862930790584, rel=1e-9)
    assert len(res.nonpassive_band_hz[0]) == 2


def _random_designs(seed, n, hard=False):
    """n design mappings around the paper example: every design parameter and filter drawn
    log-uniformly over a wide range, the plant scaled by up to 2 either way, a tenth without delay
    and a third without DOB. ``hard``: lightly damped (DOB ζ 0.003–0.05, ζ 0.01–0.2), high
    amplification, slow derivative filters and long delays, where the narrow bands and gaps are."""
    rng = np.random.default_rng(seed)
    base = read_yaml(EXAMPLE)
    out = []
    while len(out) < n:
        m = copy.deepcopy(base)
        m["humans"], m["environment"] = [], []

        def lu(a, b):
            return float(10 ** rng.uniform(np.log10(a), np.log10(b)))

        m["design"].update(amplification=lu(1.5, 40), felt_inertia=lu(0.05, 0.5), felt_damping=lu(0.01, 3),
                           zeta=lu(0.02, 1.5), zeta_hat=lu(0.02, 1.5))
        im = m["implementation"]
        im["delay_s"] = 0.0 if rng.random() < 0.1 else float(rng.uniform(0.0002, 0.006))
        im["gv_filter"] = {"cutoff_hz": lu(7, 700), "damping": lu(0.05, 1.4)}
        im["derivative_filter"] = {"cutoff_hz": lu(7, 300)}
        im["dob"] = None if rng.random() < 0.3 else {"cutoff_hz": lu(5, 170), "damping": lu(0.01, 1.4)}
        m["plant"] = {k: float(v * lu(0.5, 2)) for k, v in m["plant"].items()}
        if hard:
            m["design"].update(amplification=lu(4, 60), zeta=lu(0.01, 0.2), zeta_hat=lu(0.01, 0.5),
                               felt_damping=lu(0.005, 0.5))
            im.update(dob={"cutoff_hz": lu(5, 170), "damping": lu(0.003, 0.05)}, derivative_filter={"cutoff_hz": lu(3, 60)},
                      delay_s=float(rng.uniform(0.0005, 0.008)))
        out.append(m)
    return out


@pytest.mark.parametrize("hard", [False, True])
def test_random_designs_around_the_paper_example(hard):
    checked = 0
    for m in _random_designs(7, 32 if not hard else 20, hard):
        res = _passivity(m)
        top = float(res.max_phase_excess_deg[0])
        if math.isnan(top):  # partial coverage: no metric
            continue
        _check(_dense_reference(m), top, res.nonpassive_band_hz[0])
        checked += 1
    assert checked >= (28 if not hard else 16)


def test_points_of_the_verification_grid():
    """Points of the verification's 648-design grid around the paper example (amplification,
    delay, G_v filter, ζ̂, DOB cutoff, felt damping), analysed as one batch: errors of the maximum
    up to 0.28° there."""
    base = read_yaml(EXAMPLE)
    base["humans"], base["environment"] = [], []
    axes = {"design.amplification": [2.0, 4.0, 8.0], "implementation.delay_s": [0.001, 0.002, 0.003],
            "implementation.gv_filter.damping": [0.05, 0.1, 0.3], "implementation.gv_filter.cutoff_hz": [150.0, 300.0, 700.0],
            "design.zeta_hat": [0.2, 0.4], "implementation.dob.cutoff_hz": [20.0, 60.0],
            "design.felt_damping": [0.02, 1.0]}
    rng = np.random.default_rng(3)
    pts = [[v[rng.integers(len(v))] for v in axes.values()] for _ in range(24)]
    pts.append([8.0, 0.003, 0.05, 300.0, 0.4, 20.0, 0.02])  # the example of the verification
    pts.append([4.0, 0.003, 0.05, 300.0, 0.2, 20.0, 0.02])
    res = analyze_batch(batch_config(design_from_mapping(base), {k: np.array([p[i] for p in pts])
                                                                  for i, k in enumerate(axes)})).passivity
    for j, p in enumerate(pts):
        m = copy.deepcopy(base)
        for k, v in zip(axes, p):
            node = m
            for part in k.split(".")[:-1]:
                node = node[part]
            node[k.split(".")[-1]] = v
        _check(_dense_reference(m), float(res.max_phase_excess_deg[j]), res.nonpassive_band_hz[j])
