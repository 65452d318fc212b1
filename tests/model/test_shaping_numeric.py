"""docs/method.md#double-compliance-shaping identities checked numerically on >= 10^4 random plants per test (exotune.model.plant,
exotune.model.shaping, exotune.model.controller), plus sanity tests of the independent reference model
(tests/reference_model.py).

Random plants: J_m, B_m, K_s, J_j, K_c, felt inertia and felt damping log-uniform over six decades
each (α over three, ζ and ζ̂ over two),
evaluated at random complex s (|s| log-uniform over six decades around sqrt(K_s/Ĵ_m), random
phase; s = 0 avoided). Hypothesis draws the seeds; each example evaluates a whole batch in one
vectorized call.

Tolerance policy. An identity a(s) = b(s) passes at a point when
    |a − b| <= 1e-8 (|a| + |b|)                                       (strict), or
    |a − b| <= 1e2 · eps · (κ_a + κ_b) (|a| + |b|)                   (rounding-limited),
where κ is the componentwise relative condition number of the *formulation* (sum over every input
parameter / coefficient and s of |∂f/∂p · p|/|f|, by forward differences). Table II in float64 has
genuine cancellations (e.g. B_m + B1 = J_m B̃1 ≪ B_m when the design removes almost all motor
damping), so a handful of extreme draws are rounding-limited; at most 1 % of the points may use the
second clause, and the κ-bound is only computed for them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

import reference_model as ref
from exotune.model.controller import FirstOrderFilter, Implementation, SecondOrderFilter, build_controller
from exotune.model.plant import Plant, Tf, seven_systems
from exotune.numerics.poly import Rational
from exotune.model.shaping import (
    DesignParams,
    SeaGains,
    SeaShape,
    double_compliance_shaping,
    nominal_transfer_functions,
    sea_gains_from_shape,
    sea_shape_from_gains,
    to_deflection_units,
    to_torque_units,
)

EPS = np.finfo(float).eps
N_BATCH = 5000  # plants per hypothesis example
N_EXAMPLES = 2  # => 10^4 plants per identity
K_POINTS = 3  # random s points per plant
SEEDS = st.integers(min_value=0, max_value=2**32 - 1)
# shrinking a seed is meaningless (and slow): generate only
BATCH_SETTINGS = settings(
    max_examples=N_EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    phases=(Phase.explicit, Phase.reuse, Phase.generate),
)


# ----------------------------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------------------------
def col(x):
    return np.asarray(x, dtype=float)[:, None]


def loguniform(rng, lo, hi, n):
    return 10.0 ** rng.uniform(math.log10(lo), math.log10(hi), n)


def draw_batch(seed: int, n: int = N_BATCH, k: int = K_POINTS):
    rng = np.random.default_rng(seed)
    P = dict(
        J_m=loguniform(rng, 1e-3, 1e3, n),
        B_m=loguniform(rng, 1e-2, 1e4, n),
        K_s=loguniform(rng, 1e1, 1e7, n),
        J_j=loguniform(rng, 1e-3, 1e3, n),
        K_c=loguniform(rng, 1e0, 1e6, n),
    )
    D = dict(
        amplification=loguniform(rng, 1.0, 1e3, n),
        felt_inertia=loguniform(rng, 1e-4, 1e2, n),
        felt_damping=loguniform(rng, 1e-3, 1e3, n),
        zeta=loguniform(rng, 0.05, 5.0, n),
        zeta_hat=loguniform(rng, 0.05, 5.0, n),
    )
    plant = Plant(P["J_m"], P["B_m"], P["K_s"], P["J_j"], P["K_c"])
    design = DesignParams(**D)
    ds = double_compliance_shaping(plant, design)
    w0 = np.sqrt(P["K_s"] / ds.J_m_hat)
    mag = w0[:, None] * 10.0 ** rng.uniform(-3, 3, (n, k))
    s = mag * np.exp(1j * rng.uniform(-np.pi, np.pi, (n, k)))
    return rng, P, D, plant, design, ds, s


def _take(P: dict, rows) -> dict:
    return {k: np.asarray(v)[rows] for k, v in P.items()}


def condition(fn, P: dict, s: np.ndarray) -> np.ndarray:
    """Componentwise relative condition number of fn(P, s) by forward differences; the max over
    steps 1e-6, 1e-9, 1e-12 (a single step saturates once step·κ ≳ 1, underestimating κ)."""
    return np.maximum.reduce([_condition(fn, P, s, d) for d in (1e-6, 1e-9, 1e-12)])


def _condition(fn, P: dict, s: np.ndarray, delta: float) -> np.ndarray:
    f0 = fn(P, s)
    acc = np.zeros(s.shape)
    for key, v in P.items():
        v = np.asarray(v, dtype=float)
        cols = range(v.shape[1]) if v.ndim == 2 else [None]
        for c in cols:
            w = v.copy()
            if c is None:
                w = w * (1 + delta)
            else:
                w[:, c] *= 1 + delta
            acc += np.abs(fn({**P, key: w}, s) - f0)
    acc += np.abs(fn(P, s * (1 + delta)) - f0)
    return acc / (delta * np.abs(f0))


def assert_identity(lhs, rhs, P: dict, s: np.ndarray, what: str, rtol: float = 1e-8, max_loose=0.01):
    a, b = lhs(P, s), rhs(P, s)
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(b)), what
    scale = np.abs(a) + np.abs(b)
    err = np.abs(a - b) / scale
    bad_rows = np.flatnonzero(np.any(err > rtol, axis=-1))
    frac = bad_rows.size / err.shape[0]
    assert frac <= max_loose, f"{what}: {frac:.2%} of the plants miss the strict tolerance (max err {err.max():.3g})"
    if bad_rows.size:
        Ps, ss = _take(P, bad_rows), s[bad_rows]
        kappa = condition(lhs, Ps, ss) + condition(rhs, Ps, ss)
        e = err[bad_rows]
        ok = (e <= rtol) | (e <= 1e2 * EPS * kappa)
        worst = np.argmax(np.where(ok, 0, e / (EPS * kappa)))
        i, j = np.unravel_index(worst, e.shape)
        assert ok.all(), (
            f"{what}: error {e[i, j]:.3g} exceeds rounding bound (kappa {kappa[i, j]:.3g}) at "
            f"s={ss[i, j]!r}, params={ {k: np.asarray(v)[i].tolist() for k, v in Ps.items()} }"
        )


def params_of(P, ds, nt):
    """Flat parameter dict (inputs to seven_systems and the nominal rationals)."""
    g = ds.gains
    out = dict(P)
    out.update({k: np.asarray(v, float) for k, v in g.as_dict().items()})
    out.update(Jh=ds.J_m_hat, Bh=ds.B_m_hat, Gv_num=nt["G_v"].num, Gv_den=nt["G_v"].den)
    for name, r in nt.items():  # every nominal rational, so row subsets stay consistent
        out[name + "_num"], out[name + "_den"] = np.asarray(r.num, float), np.asarray(r.den, float)
    return out


def nominal(name):
    """fn(Q, s) evaluating exotune's nominal rational ``name`` from the parameter dict."""
    return lambda Q, x: Rational(Q[name + "_num"], Q[name + "_den"])(x)


def table2(Q, s, with_cuff=True):
    plant = Plant(col(Q["J_m"]), col(Q["B_m"]), col(Q["K_s"]), col(Q["J_j"]), col(Q["K_c"]))
    Gt = Tf(lambda x: -(col(Q["K1"]) + col(Q["B1"]) * x))
    Gs = Tf(lambda x: col(Q["K2"]) + col(Q["B2"]) * x)
    if with_cuff:
        Gv = Rational(Q["Gv_num"], Q["Gv_den"])
        Gc = Tf(lambda x: Gv(x) * (col(Q["K2_hat"]) + col(Q["B2_hat"]) * x))
    else:
        Gc = Tf.const(0.0)
    return seven_systems(plant, Gt, Gs, Gc)


# ----------------------------------------------------------------------------------------------
# shaping formulas and round trips
# ----------------------------------------------------------------------------------------------
def _close(a, b, mag, what, k=16):
    """|a − b| <= k·eps·mag where mag is the sum of magnitudes of the terms of the formula."""
    a, b, mag = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float), np.asarray(mag, float))
    bad = np.abs(a - b) > k * EPS * mag + 1e-300
    assert not bad.any(), f"{what}: max violation {np.max(np.abs(a - b)[bad] / mag[bad]):.3g}·mag"


@BATCH_SETTINGS
@given(seed=SEEDS)
def test_double_shaping_gains_match_spec(seed):
    _, P, D, plant, design, ds, _ = draw_batch(seed)
    J_m, B_m, K_s, K_c = P["J_m"], P["B_m"], P["K_s"], P["K_c"]
    a = D["amplification"]
    Jh, Bh = a * D["felt_inertia"], a * D["felt_damping"]
    B1t, K2t, B2t = Bh / Jh, K_s / Jh, 2 * D["zeta"] * np.sqrt(K_s / Jh)
    g, sh = ds.gains, ds.shape
    _close(ds.J_m_hat, Jh, Jh, "J_m_hat")
    _close(ds.B_m_hat, Bh, Bh, "B_m_hat")
    assert np.all(sh.K1_tilde == 0) and np.all(g.K1 == 0)
    _close(sh.B1_tilde, B1t, B1t, "B1_tilde")
    _close(sh.K2_tilde, K2t, K2t, "K2_tilde")
    _close(sh.B2_tilde, B2t, B2t, "B2_tilde")
    _close(g.B1, J_m * B1t - B_m, J_m * B1t + B_m, "B1")
    _close(g.K2, J_m / Jh - 1, J_m / Jh + 1, "K2 [torque units]")
    _close(g.B2, (B2t - B1t) * J_m / K_s, (B2t + B1t) * J_m / K_s, "B2 [s]")
    _close(g.K2_hat, a - 1, a, "K2_hat")
    bh = 2 * D["zeta_hat"] * np.sqrt(a * K_c * Jh)
    _close(g.B2_hat, (bh - Bh) / K_c, (bh + Bh) / K_c, "B2_hat")


@BATCH_SETTINGS
@given(seed=SEEDS)
def test_sea_shape_round_trips_both_units(seed):
    rng, P, _, plant, _, _, _ = draw_batch(seed)
    n = P["J_m"].size
    shape = SeaShape(
        K1_tilde=loguniform(rng, 1e-3, 1e5, n) * rng.choice([0.0, 1.0], n),
        B1_tilde=loguniform(rng, 1e-3, 1e3, n),
        K2_tilde=loguniform(rng, 1e-2, 1e6, n),
        B2_tilde=loguniform(rng, 1e-3, 1e3, n),
    )
    J_m, B_m, K_s = P["J_m"], P["B_m"], P["K_s"]
    gt = sea_gains_from_shape(plant, shape, "torque")
    gd = sea_gains_from_shape(plant, shape, "deflection")
    assert gt.units == "torque" and gd.units == "deflection"
    # eq. (9) in deflection units, ×1/K_s in torque units
    _close(gd.K1, J_m * shape.K1_tilde, J_m * shape.K1_tilde, "K1")
    _close(gd.K2, J_m * (shape.K2_tilde - shape.K1_tilde) - K_s, J_m * (shape.K2_tilde + shape.K1_tilde) + K_s, "K2")
    _close(gd.B1, J_m * shape.B1_tilde - B_m, J_m * shape.B1_tilde + B_m, "B1")
    _close(gd.B2, J_m * (shape.B2_tilde - shape.B1_tilde), J_m * (shape.B2_tilde + shape.B1_tilde), "B2")
    _close(gt.K1, gd.K1, np.abs(gd.K1), "K1 units")
    _close(gt.B1, gd.B1, np.abs(gd.B1), "B1 units")
    _close(gt.K2 * K_s, gd.K2, np.abs(gd.K2), "K2 units", k=4)
    _close(gt.B2 * K_s, gd.B2, np.abs(gd.B2), "B2 units", k=4)
    # conversions are inverse to each other and the identity on their own convention
    for g in (gt, gd):
        back = sea_shape_from_gains(plant, g)
        for name in ("K1_tilde", "B1_tilde", "K2_tilde", "B2_tilde"):
            mag = {
                "K1_tilde": shape.K1_tilde,
                "B1_tilde": shape.B1_tilde + 2 * B_m / J_m,
                "K2_tilde": shape.K2_tilde + 2 * shape.K1_tilde + 2 * K_s / J_m,
                "B2_tilde": shape.B2_tilde + 2 * shape.B1_tilde + 2 * B_m / J_m,
            }[name]
            _close(getattr(back, name), getattr(shape, name), mag, f"shape round trip {name} ({g.units})")
    assert to_torque_units(plant, gt) is gt and to_deflection_units(plant, gd) is gd
    td = to_deflection_units(plant, gt)
    tt = to_torque_units(plant, gd)
    for name in ("K1", "B1", "K2", "B2"):
        _close(getattr(td, name), getattr(gd, name), np.abs(getattr(gd, name)), f"to_deflection {name}", k=8)
        _close(getattr(tt, name), getattr(gt, name), np.abs(getattr(gt, name)), f"to_torque {name}", k=8)
    # gains -> shape -> gains for arbitrary gains (both conventions)
    g0 = SeaGains(
        K1=loguniform(rng, 1e-2, 1e4, n),
        B1=rng.uniform(-1, 1, n) * B_m,
        K2=rng.uniform(-0.9, 10, n),
        B2=loguniform(rng, 1e-6, 1e-1, n),
        units="torque",
    )
    for g in (g0, to_deflection_units(plant, g0)):
        sh = sea_shape_from_gains(plant, g)
        g2 = sea_gains_from_shape(plant, sh, g.units)
        gdef = to_deflection_units(plant, g)
        scale = {
            "K1": np.abs(gdef.K1),
            "B1": np.abs(gdef.B1) + B_m,
            "K2": np.abs(gdef.K2) + 2 * (K_s + np.abs(gdef.K1)),
            "B2": np.abs(gdef.B2) + 2 * (np.abs(gdef.B1) + B_m),
        }
        for name in ("K1", "B1", "K2", "B2"):
            unit = K_s if (g.units == "torque" and name in ("K2", "B2")) else 1.0
            _close(getattr(g2, name), getattr(g, name), scale[name] / unit, f"gain round trip {name} ({g.units})", k=32)


# ----------------------------------------------------------------------------------------------
# docs/method.md#double-compliance-shaping identities (zero delay, no filters)
# ----------------------------------------------------------------------------------------------
@BATCH_SETTINGS
@given(seed=SEEDS)
def test_H5_Gv_is_virtual_motor(seed):
    _, P, _, plant, design, ds, s = draw_batch(seed)
    nt = nominal_transfer_functions(plant, design, ds)
    Q0 = params_of(P, ds, nt)
    assert_identity(
        lambda Q, x: table2(Q, x, with_cuff=False)["S5"].H(x) * Rational(Q["Gv_num"], Q["Gv_den"])(x),
        lambda Q, x: 1.0 / (col(Q["Jh"]) * x * x + col(Q["Bh"]) * x),
        Q0,
        s,
        "H5·G_v = 1/(Ĵ_m s² + B̂_m s)",
    )
    # exotune's own Ĉ5 rational is the same virtual motor
    c5h = nt["C5_hat"](s)
    assert np.allclose(c5h, 1.0 / (col(ds.J_m_hat) * s * s + col(ds.B_m_hat) * s), rtol=1e-12, atol=0)


@BATCH_SETTINGS
@given(seed=SEEDS)
def test_C4_and_C5_match_compliance_shape(seed):
    _, P, _, plant, design, ds, s = draw_batch(seed)
    nt = nominal_transfer_functions(plant, design, ds)
    Q0 = params_of(P, ds, nt)
    Q0.update(B1t=ds.shape.B1_tilde, K2t=ds.shape.K2_tilde, B2t=ds.shape.B2_tilde)

    def target_C4(Q, x):
        return (x * x + col(Q["B2t"]) * x + col(Q["K2t"])) / (col(Q["K_s"]) * (x * x + col(Q["B1t"]) * x))

    def total_C5(Q, x):
        N = x * x + col(Q["B2t"]) * x + col(Q["K2t"])
        return N / (col(Q["J_j"]) * x * x * N + col(Q["K_s"]) * (x * x + col(Q["B1t"]) * x))

    assert_identity(lambda Q, x: table2(Q, x, False)["S4"].C(x), target_C4, Q0, s, "C4 = target")
    assert_identity(lambda Q, x: table2(Q, x, False)["S5"].C(x), total_C5, Q0, s, "C5 = eq. (10)")
    assert_identity(nominal("C4"), target_C4, Q0, s, "nominal C4")
    assert_identity(nominal("C5"), total_C5, Q0, s, "nominal C5")


@BATCH_SETTINGS
@given(seed=SEEDS)
def test_C6_over_C5_tends_to_alpha(seed):
    _, P, D, plant, design, ds, _ = draw_batch(seed)
    nt = nominal_transfer_functions(plant, design, ds)
    Q0 = params_of(P, ds, nt)
    sh, g = ds.shape, ds.gains
    a = D["amplification"]
    Q0["alpha"] = a
    # r(s) = C6/C5 = α + c s + O(s²), c = (α−1)[J_j/(Ĵ_m B̃1) − B̃2/K̃2] + B̂2 (derived by hand);
    # pick s so that the O(s) term is ~1e-10 relative.
    c = (a - 1) * (P["J_j"] / (ds.J_m_hat * sh.B1_tilde) - sh.B2_tilde / sh.K2_tilde) + g.B2_hat
    w_min = np.minimum.reduce([sh.B1_tilde, np.sqrt(sh.K2_tilde), sh.K2_tilde / sh.B2_tilde, a / (np.abs(c) + 1e-300)])
    s0 = (1e-10 * w_min)[:, None] * np.exp(1j * np.array([[0.3, 1.2, -2.0]]))
    ratio = lambda Q, x: (lambda S: S["S6"].C(x) / S["S5"].C(x))(table2(Q, x))  # noqa: E731
    assert_identity(ratio, lambda Q, x: col(Q["alpha"]) + 0 * x, Q0, s0, "C6/C5 -> α (s -> 0)")
    # the first-order term is right too (a non-trivial check that the limit is approached)
    s1 = (1e-4 * w_min)[:, None] * np.exp(1j * np.array([[0.7]]))
    slope = (ratio(Q0, s1) - col(a)) / s1
    rel = np.abs(slope - col(c)) / (np.abs(slope) + np.abs(col(c)) + np.abs(col(a) / s1) * 1e-9)
    assert np.median(rel) < 1e-4 and np.quantile(rel, 0.99) < 1e-2


@BATCH_SETTINGS
@given(seed=SEEDS)
def test_nominal_C7_is_C6_plus_cuff_with_C5_hat(seed):
    _, P, D, plant, design, ds, s = draw_batch(seed)
    nt = nominal_transfer_functions(plant, design, ds)
    Q0 = params_of(P, ds, nt)
    Q0.update(alpha=D["amplification"], zh=D["zeta_hat"])

    def corrected(Q, x):  # eq. (16) with the erratum fixed
        w2 = col(Q["alpha"]) * col(Q["K_c"]) / col(Q["Jh"])
        return (x * x + 2 * col(Q["zh"]) * np.sqrt(w2) * x + w2) / (col(Q["K_c"]) * (x * x + col(Q["Bh"]) / col(Q["Jh"]) * x))

    def replaced(Q, x):  # C6 + 1/K_c with C5 replaced by Ĉ5, from Table II
        S = table2(Q, x)
        return S["S7"].C(x) - S["S5"].C(x) + 1.0 / (col(Q["Jh"]) * x * x + col(Q["Bh"]) * x)

    assert_identity(replaced, corrected, Q0, s, "C7_nom = C6 + 1/K_c with C5 -> Ĉ5")
    assert_identity(nominal("C7_nominal"), corrected, Q0, s, "exotune C7_nominal")
    # the paper's printed form (middle term without s) is a different function
    w2 = col(D["amplification"] * P["K_c"] / ds.J_m_hat)
    printed = (s * s + 2 * col(D["zeta_hat"]) * np.sqrt(w2) + w2) / (col(P["K_c"]) * (s * s + col(ds.B_m_hat / ds.J_m_hat) * s))
    c = corrected(Q0, s)
    assert np.median(np.abs(printed - c) / (np.abs(printed) + np.abs(c))) > 1e-3


@BATCH_SETTINGS
@given(seed=SEEDS)
def test_nominal_Gv_matches_paper(seed):
    _, P, _, plant, design, ds, s = draw_batch(seed)
    nt = nominal_transfer_functions(plant, design, ds)
    sh = ds.shape
    Q0 = params_of(P, ds, nt)
    Q0.update(B1t=sh.B1_tilde, K2t=sh.K2_tilde, B2t=sh.B2_tilde)

    def gv(Q, x):
        N = x * x + col(Q["B2t"]) * x + col(Q["K2t"])
        return col(Q["J_m"] / Q["Jh"]) * (1 + col(Q["J_j"] / Q["K_s"]) * x * x * N / (x * x + col(Q["B1t"]) * x))

    assert_identity(lambda Q, x: Rational(Q["Gv_num"], Q["Gv_den"])(x), gv, Q0, s, "G_v")


# ----------------------------------------------------------------------------------------------
# implemented cuff path G_c,impl (docs/method.md#controller) vs exotune.model.controller
# ----------------------------------------------------------------------------------------------
@BATCH_SETTINGS
@given(seed=SEEDS)
def test_controller_cuff_path_matches_spec(seed):
    rng, P, D, plant, design, ds, s = draw_batch(seed)
    n = P["J_m"].size
    fv, zv, fd = loguniform(rng, 1.0, 1e4, n), rng.uniform(0.2, 1.5, n), loguniform(rng, 1.0, 1e4, n)
    impl = Implementation(gv_filter=SecondOrderFilter(fv, zv), derivative_filter=FirstOrderFilter(fd))
    sh, g = ds.shape, ds.gains
    Q0 = dict(
        J_m=P["J_m"], J_j=P["J_j"], K_s=P["K_s"], Jh=ds.J_m_hat, B1t=sh.B1_tilde, K2t=sh.K2_tilde,
        B2t=sh.B2_tilde, K2h=np.asarray(g.K2_hat, float), B2h=np.asarray(g.B2_hat, float),
        wv=2 * np.pi * fv, zv=zv, wd=2 * np.pi * fd,
    )

    def spec_default(Q, x):
        Fv = col(Q["wv"]) ** 2 / (x * x + 2 * col(Q["zv"] * Q["wv"]) * x + col(Q["wv"]) ** 2)
        Fd = col(Q["wd"]) / (x + col(Q["wd"]))
        N = x * (x * x + col(Q["B2t"]) * x + col(Q["K2t"]))
        inner = 1 + col(Q["J_j"] / Q["K_s"]) * Fv * N / (x + col(Q["B1t"]))
        return col(Q["J_m"] / Q["Jh"]) * inner * (col(Q["K2h"]) + col(Q["B2h"]) * x * Fd)

    def spec_full_filter(Q, x):
        Fv = col(Q["wv"]) ** 2 / (x * x + 2 * col(Q["zv"] * Q["wv"]) * x + col(Q["wv"]) ** 2)
        Fd = col(Q["wd"]) / (x + col(Q["wd"]))
        N = x * x + col(Q["B2t"]) * x + col(Q["K2t"])
        Gv = col(Q["J_m"] / Q["Jh"]) * (1 + col(Q["J_j"] / Q["K_s"]) * x * x * N / (x * x + col(Q["B1t"]) * x))
        return Fv * Fd * Gv * (col(Q["K2h"]) + col(Q["B2h"]) * x)

    cs, ds2 = build_controller(plant, design, impl)
    assert np.all(cs.cuff_torque.is_proper())
    gc = cs.cuff_torque
    Q1 = dict(Q0, num=gc.num, den=gc.den)
    assert_identity(lambda Q, x: Rational(Q["num"], Q["den"])(x), spec_default, Q1, s, "G_c,impl default")
    cs2, _ = build_controller(plant, design, Implementation(gv_filter=impl.gv_filter, derivative_filter=impl.derivative_filter, structure="full_filter"))
    Q2 = dict(Q0, num=cs2.cuff_torque.num, den=cs2.cuff_torque.den)
    assert_identity(lambda Q, x: Rational(Q["num"], Q["den"])(x), spec_full_filter, Q2, s, "G_c full_filter")
    # SEA blocks: G_θ = −(K1 + B1 s), G_s = K2 + B2 s (ideal velocities)
    assert np.allclose(cs.motor_position(s), -(col(g.K1) + col(g.B1) * s), rtol=1e-13)
    assert np.allclose(cs.spring_torque(s), col(g.K2) + col(g.B2) * s, rtol=1e-13)


def test_reference_gc_matches_exotune_and_spec():
    """The reference's own polynomial G_c (tests/reference_model.reference_gc) equals exotune's
    controller block in frequency response, for the docs/design-file.md design and random variants."""
    rng = np.random.default_rng(7)
    base_p = dict(J_m=0.44, B_m=17.9, K_s=1180.0, J_j=0.29, K_c=300.0)
    base_d = dict(amplification=8.0, felt_inertia=0.25, felt_damping=1.0, zeta=0.7, zeta_hat=0.7)
    for trial in range(20):
        f = (lambda: 1.0) if trial == 0 else (lambda: 10 ** rng.uniform(-1, 1))
        p = {k: v * f() for k, v in base_p.items()}
        d = {k: v * f() for k, v in base_d.items()}
        d["amplification"] = max(1.0, d["amplification"])
        gvf, dvf = {"cutoff_hz": 80.0 * f(), "damping": 0.7}, {"cutoff_hz": 100.0 * f()}
        num, den = ref.reference_gc(p, d, gvf, dvf)
        plant = Plant(*[np.array([p[k]]) for k in ("J_m", "B_m", "K_s", "J_j", "K_c")])
        design = DesignParams(*[np.array([d[k]]) for k in ("amplification", "felt_inertia", "felt_damping", "zeta", "zeta_hat")])
        impl = Implementation(gv_filter=SecondOrderFilter(gvf["cutoff_hz"], 0.7), derivative_filter=FirstOrderFilter(dvf["cutoff_hz"]))
        cs, ds = build_controller(plant, design, impl)
        gref = ref.reference_gains(p, d)
        for k in ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat"):
            assert np.isclose(float(np.ravel(getattr(ds.gains, k))[0]), gref[k], rtol=1e-12, atol=1e-12 * (abs(gref["B1"]) + p["B_m"]))
        w = 2 * np.pi * np.logspace(-2, 4, 60)
        x = np.concatenate([1j * w, w * np.exp(0.6j), -0.3 * w + 2j * w])
        a = np.polynomial.polynomial.polyval(x, num) / np.polynomial.polynomial.polyval(x, den)
        b = Rational(np.atleast_2d(cs.cuff_torque.num)[0], np.atleast_2d(cs.cuff_torque.den)[0])(x)
        np.testing.assert_allclose(a, b, rtol=1e-10)


# ----------------------------------------------------------------------------------------------
# sanity of the reference model itself
# ----------------------------------------------------------------------------------------------
P_ = np.polynomial.Polynomial
PAPER_PLANT = dict(J_m=0.44, B_m=17.9, K_s=1180.0, J_j=0.29, K_c=300.0)
PAPER_DESIGN = dict(amplification=8.0, felt_inertia=0.25, felt_damping=1.0, zeta=0.7, zeta_hat=0.7)


def _det(M):
    if len(M) == 1:
        return M[0][0]
    return sum(((-1) ** j) * M[0][j] * _det([row[:j] + row[j + 1 :] for row in M[1:]]) for j in range(len(M)))


def hand_char_poly(plant, gains, human, env):
    """det of the polynomial matrix of eq. (5) + controller (zero delay, no DOB), motor row
    multiplied by the G_c denominator; unknowns (θ_m, θ_j, θ_h) minus removed ones."""
    J_m, B_m, K_s, J_j, K_c = (plant[k] for k in ("J_m", "B_m", "K_s", "J_j", "K_c"))
    K1, B1, K2, B2 = (gains.get(k, 0.0) for k in ("K1", "B1", "K2", "B2"))
    gn, gd = (P_(gains["Gc"][0]), P_(gains["Gc"][1])) if gains.get("Gc") is not None else (P_([0.0]), P_([1.0]))
    s = P_([0.0, 1.0])
    locked = env == "locked"
    Ze = P_([0.0])
    if isinstance(env, dict):
        Ze = env.get("stiffness", 0.0) + env.get("damping", 0.0) * s + env.get("inertia", 0.0) * s**2
    cuff = human is not None
    Zh = None
    if cuff:
        Zh = human.get("stiffness", 0.0) + human.get("damping", 0.0) * s + human.get("inertia", 0.0) * s**2
    # motor: (J_m s² + B_m s) θ_m − τ_s − τ_cmd = 0, τ_cmd = −(K1+B1 s)θ_m + (K2+B2 s)τ_s + G_c τ_c
    Gs = K2 + B2 * s
    m_m = gd * (J_m * s**2 + B_m * s + K_s + K1 + B1 * s + Gs * K_s)
    m_j = gd * (-K_s - Gs * K_s) + (gn * K_c if cuff else 0 * s)
    m_h = -gn * K_c
    j_m = P_([-K_s])
    j_j = J_j * s**2 + K_s + Ze + (K_c if cuff else 0.0)
    j_h = P_([-K_c])
    h_j, h_h = P_([-K_c]), (Zh + K_c if cuff else None)
    if locked:
        M = [[m_m, m_h], [P_([0.0]), h_h]] if cuff else [[m_m]]
    else:
        M = [[m_m, m_j, m_h], [j_m, j_j, j_h], [P_([0.0]), h_j, h_h]] if cuff else [[m_m, m_j], [j_m, j_j]]
    return _det(M)


def match_roots(a, b, rtol):
    a, b = np.asarray(a, complex), np.asarray(b, complex)
    assert a.size == b.size, (a.size, b.size)
    cost = np.abs(a[:, None] - b[None, :])
    r, c = linear_sum_assignment(cost)
    scale = np.maximum(1.0, np.abs(a[r]))
    worst = np.max(cost[r, c] / scale)
    assert worst <= rtol, f"roots differ by {worst:.3g} (relative)\n{np.sort_complex(a)}\n{np.sort_complex(b)}"


HUMANS = [
    None,
    {"kind": "spring", "stiffness": 50.0},
    {"kind": "spring", "stiffness": 50.0, "damping": 0.7},
    {"kind": "mass", "inertia": 0.08},
    {"kind": "mass", "inertia": 0.08, "damping": 0.3},
    {"kind": "msd", "inertia": 0.1, "damping": 0.5, "stiffness": 20.0},
]
ENVS = ["free", "locked", {"kind": "spring", "value": 400.0, "damping": 1.0}, {"kind": "mass", "value": 0.5}]


def _env_hand(env):
    if isinstance(env, dict):
        return {"stiffness": env["value"] if env["kind"] == "spring" else 0.0,
                "inertia": env["value"] if env["kind"] == "mass" else 0.0,
                "damping": env.get("damping", 0.0)}
    return env


def _rand_plant(rng, spread=1.0):
    return {k: v * 10 ** rng.uniform(-spread, spread) for k, v in PAPER_PLANT.items()}


@pytest.mark.parametrize("env", ENVS, ids=lambda e: e if isinstance(e, str) else e["kind"])
@pytest.mark.parametrize("human", HUMANS, ids=lambda h: "none" if h is None else f"{h['kind']}{'_b' if h.get('damping') else ''}")
def test_reference_open_loop_poles_are_physical_roots(human, env):
    rng = np.random.default_rng(11)
    for _ in range(5):
        plant = _rand_plant(rng)
        poles = ref.closed_loop_poles(plant, {}, None, human, env)
        char = hand_char_poly(plant, {}, human, _env_hand(env))
        match_roots(poles, char.roots(), 1e-7)
    # explicit closed form for the bare free plant: s·(J_m J_j s³ + B_m J_j s² + K_s(J_m+J_j) s + K_s B_m)
    if human is None and env == "free":
        J_m, B_m, K_s, J_j = (plant[k] for k in ("J_m", "B_m", "K_s", "J_j"))
        roots = np.concatenate([[0.0], np.roots([J_m * J_j, B_m * J_j, K_s * (J_m + J_j), K_s * B_m])])
        match_roots(poles, roots, 1e-9)


@pytest.mark.parametrize("env", ENVS, ids=lambda e: e if isinstance(e, str) else e["kind"])
@pytest.mark.parametrize("human", HUMANS, ids=lambda h: "none" if h is None else f"{h['kind']}{'_b' if h.get('damping') else ''}")
def test_reference_closed_loop_poles_match_hand_char_poly(human, env):
    rng = np.random.default_rng(12)
    for _ in range(4):
        plant = _rand_plant(rng, 0.5)
        design = {k: v * 10 ** rng.uniform(-0.5, 0.5) for k, v in PAPER_DESIGN.items()}
        design["amplification"] = 1 + 10 * rng.uniform()
        gains = ref.reference_gains(plant, design)
        gains["K1"] = rng.choice([0.0, 50.0])
        gains["Gc"] = ref.reference_gc(plant, design, {"cutoff_hz": 60 * 10 ** rng.uniform(-0.5, 0.5), "damping": 0.7}, {"cutoff_hz": 100.0})
        poles = ref.closed_loop_poles(plant, gains, {"T": 0.0}, human, env)
        char = hand_char_poly(plant, gains, human, _env_hand(env))
        assert poles.size == char.degree()
        match_roots(poles, char.roots(), 1e-6)


def test_reference_dob_is_invisible_without_delay():
    """T = 0, perfect model: the DOB adds only the (uncontrollable) Q poles, twice."""
    rng = np.random.default_rng(13)
    for human in HUMANS:
        plant = _rand_plant(rng, 0.3)
        gains = ref.reference_gains(plant, PAPER_DESIGN)
        gains["Gc"] = ref.reference_gc(plant, PAPER_DESIGN, {"cutoff_hz": 80.0, "damping": 0.7}, {"cutoff_hz": 100.0})
        fq, zq = 60.0, 0.6
        base = ref.closed_loop_poles(plant, gains, {"T": 0.0}, human)
        withq = ref.closed_loop_poles(plant, gains, {"T": 0.0, "dob": {"cutoff_hz": fq, "damping": zq}}, human)
        wq = 2 * np.pi * fq
        qpoles = np.roots([1.0, 2 * zq * wq, wq * wq])
        match_roots(withq, np.concatenate([base, qpoles, qpoles]), 1e-6)
        # ...but with a delay it does change the loop
        wd = ref.closed_loop_poles(plant, gains, {"T": 2e-3, "dob": {"cutoff_hz": fq, "damping": zq}}, human, pade_order=4)
        nd = ref.closed_loop_poles(plant, gains, {"T": 2e-3}, human, pade_order=4)
        d = np.abs(wd[:, None] - np.concatenate([nd, qpoles, qpoles])[None, :])
        assert d.min(axis=1).max() > 1e-3


def test_reference_rigid_body_mode():
    plant = dict(PAPER_PLANT)
    gains = ref.reference_gains(plant, PAPER_DESIGN)
    gains["Gc"] = ref.reference_gc(plant, PAPER_DESIGN, {"cutoff_hz": 80.0, "damping": 0.7}, {"cutoff_hz": 100.0})
    impl = {"T": 1e-3, "dob": {"cutoff_hz": 60.0, "damping": 0.7}}
    for human in (None, {"kind": "mass", "inertia": 0.1}, {"kind": "spring", "stiffness": 0.0, "damping": 1.0}):
        assert ref.has_rigid_body_mode(gains, human, "free")
        p = ref.closed_loop_poles(plant, gains, impl, human, "free")
        assert np.min(np.abs(p)) <= ref.RIGID_BODY_RTOL * np.max(np.abs(p))
        mr = ref.free_rigid_body_tolerant_max_real(p, True)
        assert mr < 0
        assert mr == np.max(np.delete(p, np.argmin(np.abs(p))).real)
    for human, env in ((None, "locked"), ({"kind": "spring", "stiffness": 10.0}, "free"), (None, {"kind": "spring", "value": 100.0})):
        assert not ref.has_rigid_body_mode(gains, human, env)
        p = ref.closed_loop_poles(plant, gains, impl, human, env)
        assert np.min(np.abs(p)) > 1e-3
        with pytest.raises(ValueError):
            ref.free_rigid_body_tolerant_max_real(p, True)
        assert ref.free_rigid_body_tolerant_max_real(p, False) == np.max(p.real)
    g2 = dict(gains, K1=100.0)
    assert not ref.has_rigid_body_mode(g2, None, "free")


def test_reference_paper_example_verdicts():
    """docs/design-file.md design, Padé(8) delay of 1 ms, DOB at 60 Hz: free cuff and output locked stable;
    every spring 1..1e4 N·m/rad stable; light inertias (1e-3 kg·m²) unstable, 1 kg·m² stable."""
    plant = dict(PAPER_PLANT)
    gains = ref.reference_gains(plant, PAPER_DESIGN)
    gains["Gc"] = ref.reference_gc(plant, PAPER_DESIGN, {"cutoff_hz": 80.0, "damping": 0.7}, {"cutoff_hz": 100.0})
    impl = {"T": 1e-3, "dob": {"cutoff_hz": 60.0, "damping": 0.7}}
    cases = [(None, "free", True), (None, "locked", True)]
    cases += [({"kind": "spring", "stiffness": k}, "free", True) for k in (1.0, 10.0, 100.0, 1e3, 1e4)]
    cases += [({"kind": "mass", "inertia": m}, "free", st_) for m, st_ in ((1e-3, False), (2e-3, False), (0.05, True), (1.0, True))]
    for human, env, expected in cases:
        stable, margin = ref.coupled_verdict(plant, gains, impl, human, env)
        assert margin > 1e-3, (human, env, margin)
        assert stable == expected, (human, env)
    # Padé order does not change these verdicts
    for order in (4, 6, 10):
        assert ref.coupled_verdict(plant, gains, impl, {"kind": "mass", "inertia": 1e-3}, "free", order)[0] is False
        assert ref.coupled_verdict(plant, gains, impl, {"kind": "spring", "stiffness": 1e4}, "free", order)[0] is True
